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
//!   sorts), `disjoint` (writes to disjoint parts of a slice from
//!   threads), [`progress`] (progress bars, phase times),
//!   [`alloc`](mod@alloc) (the binaries' allocator), [`frame`] (a
//!   scene's up axis and unit, and the change between two).
//! - [`column`](mod@column): scalar types and (lazily decoded) columns.
//! - [`cloud`]: the point cloud: elements, attributes, detail, faces;
//!   [`error`]: the library's error; [`memory`]: memory asked for before
//!   the work; [`image`]: image clouds, shade points that remember their
//!   pixels; [`halo`]: the points of a tile a stage computes; [`files`]:
//!   atomic output files, and the run's record of what it opened.
//! - [`formats`]: PLY (all encodings), OBJ input, OpenEXR point clouds and
//!   shade-point images, USD stages in and USD text out
//!   ([`formats::usd`]), texture images, format sniffing; [`geom`]:
//!   triangle and polygon measures, sampling, closest points; meshes
//!   ([`geom::mesh`]), rays against them ([`geom::bvh`]), neighbour search
//!   over points ([`geom::grid`], [`geom::kdtree`]).
//! - [`lights`]: the lights file, light masks, light arriving at a point,
//!   and whether it arrives: shadow rays ([`lights::shadow`]); [`medium`]:
//!   the physical medium (a material file or preset, its albedo, mean
//!   free path, `g` and `eta`), the random walk in a slab and its tables,
//!   the light a thin part lets through.
//! - [`stages`]: measure, promote, scatter, facet, follow, texture, illum,
//!   ssmulti, sssingle, filter, render.
//! - [`tiles`]: `pctile`'s split and merge, the halo a stage needs;
//!   [`tools`]: `pcinfo` and `pcdiff`, what the fuzz targets run.
//! - [`cli`]: what every binary shares (I/O paths, messages, errors,
//!   options several stages take) and each stage's command line.
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
pub mod medium;
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
