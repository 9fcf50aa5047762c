//! The stages: pure functions from clouds to clouds, one module each.
//! The binaries in `src/bin/` only parse arguments, read, call, write.

pub mod facet;
pub mod filter;
pub mod illum;
pub mod measure;
pub mod promote;
pub mod render;
pub mod scatter;
pub mod ssmulti;
pub mod sssingle;

/// Which stage makes each well-known attribute (`docs/DESIGN.md#stages`):
/// an error about a missing attribute names it.
pub const MAKERS: &[(&str, &str)] = &[
    ("area", "measure"),
    ("perimeter", "measure"),
    ("Tarea", "promote"),
    ("Tptarea", "promote"),
    ("P", "scatter"),
    ("ptarea", "scatter"),
    ("sourceprim", "scatter"),
    ("sourceuv", "scatter"),
    ("N", "facet"),
    ("illum", "illum"),
    ("ssM", "ssmulti"),
    ("ssmulti_sd", "ssmulti"),
    ("ssmulti_rd", "ssmulti"),
    ("ssS", "sssingle"),
    ("beauty", "render"),
    (crate::image::PIXEL_X, "render"),
    (crate::image::PIXEL_Y, "render"),
    (crate::image::DATA_WINDOW, "render"),
];

/// The stage that makes attribute `name`, if one does.
pub fn made_by(name: &str) -> Option<&'static str> {
    MAKERS.iter().find(|m| m.0 == name).map(|m| m.1)
}
