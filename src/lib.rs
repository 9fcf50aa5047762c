//! # pcsss: point-cloud subsurface scattering
//!
//! A toolkit for Pixar's point-based subsurface scattering ("Human Skin for
//! Finding Nemo", as Mario Marengo built it in Houdini): typed point clouds
//! that travel as PLY between separate command-line stages.
//!
//! - [`column`]: scalar types and (lazily decoded) columns.
//! - [`cloud`]: the point cloud: elements, attributes, detail, faces.
//! - [`formats`]: PLY (all encodings) and OBJ input, format sniffing.
//! - [`geom`]: triangle and polygon measures, sampling, closest points.
//! - [`mesh`]: faces as polygons, triangulation, closest-point queries.
//! - [`cli`]: what every binary shares (I/O, messages, errors).
//! - [`tools`]: `pcinfo` and `pcdiff`.
//!
//! What each stage computes is in the repository's `DESIGN.md`; the on-disk
//! conventions in `formats/`.

pub mod bvh;
pub mod cli;
pub mod cloud;
pub mod column;
pub mod error;
pub mod formats;
pub mod geom;
pub mod lights;
pub mod mesh;
pub mod progress;
pub mod stages;
pub mod tools;

pub use cloud::{AttrData, Attribute, Cloud, Detail, DetailValue, Element, ListColumn, Role};
pub use column::{Column, Scalar, ScalarType, Values};
pub use error::{Error, Result};
