//! # pcsss: point-cloud subsurface scattering
//!
//! A toolkit for Pixar's point-based subsurface scattering ("Human Skin for
//! Finding Nemo", as Mario Marengo built it in Houdini): typed point clouds
//! that travel as PLY or OpenEXR between separate command-line stages.
//!
//! The modules, lowest layer first (a module uses only its own layer and
//! those below: the repository's `docs/ARCHITECTURE.md`):
//!
//! - Leaves: [`names`] (attribute names and the stage that makes each),
//!   [`maths`] (smoothstep, seeded uniform streams), [`optics`]
//!   (refraction, Fresnel, Henyey-Greenstein), [`radix`] (radix
//!   sorts), [`progress`] (progress bars, phase times),
//!   [`alloc`](mod@alloc) (the binaries' allocator).
//! - [`column`](mod@column): scalar types and (lazily decoded) columns.
//! - [`cloud`]: the point cloud: elements, attributes, detail, faces;
//!   [`error`]: the library's error; [`memory`]: memory asked for before
//!   the work; [`image`]: image clouds, shade points that remember their
//!   pixels; [`halo`]: the points of a tile a stage computes; [`files`]:
//!   atomic output files.
//! - [`formats`]: PLY (all encodings), OBJ input, OpenEXR point clouds and
//!   shade-point images, format sniffing; [`geom`]: triangle and polygon
//!   measures, sampling, closest points; meshes ([`geom::mesh`]), rays
//!   against them ([`geom::bvh`]), neighbour search over points
//!   ([`geom::grid`], [`geom::kdtree`]).
//! - [`lights`]: the lights file, light masks, light arriving at a point,
//!   and whether it arrives: shadow rays ([`lights::shadow`]).
//! - [`stages`]: measure, promote, scatter, facet, illum, ssmulti,
//!   sssingle, filter, render.
//! - [`tiles`]: `pctile`'s split and merge, the halo a stage needs;
//!   [`tools`]: `pcinfo` and `pcdiff`.
//! - [`cli`]: what every binary shares (I/O paths, messages, errors,
//!   options several stages take).
//!
//! What each stage computes is in the repository's `docs/DESIGN.md`; the on-disk
//! conventions in `formats/`.

pub mod alloc;
pub mod cli;
pub mod cloud;
pub mod column;
pub(crate) mod disjoint;
pub mod error;
pub mod files;
pub mod formats;
pub mod frame;
pub mod geom;
pub mod halo;
pub mod image;
pub mod lights;
pub mod maths;
pub mod memory;
pub mod names;
pub mod optics;
pub mod progress;
pub mod radix;
pub mod stages;
pub mod tiles;
pub mod tools;

pub use cloud::{AttrData, Attribute, Cloud, Detail, DetailValue, Element, ListColumn, Role};
pub use column::{Column, Scalar, ScalarType, Values};
pub use error::{Error, Result};
