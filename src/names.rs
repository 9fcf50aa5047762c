//! The well-known attribute names and the stage that makes each: a leaf
//! table, read by [`crate::error`] (a missing attribute names its maker)
//! and by the stages and tiles that write them.

/// Point attribute of a tile (uchar): 1 for a halo point (a source, never
/// a receiver), 0 for a point the tile owns.
pub const HALO: &str = "pctile_halo";
/// Point attribute of a tile (uint): the point's row in the input.
pub const INDEX: &str = "pctile_index";
/// Detail of a tile: the split's id (str), the manifest's checksum.
pub const D_SPLIT: &str = "pctile_split";
/// Detail of a tile: the tile's number (i32).
pub const D_TILE: &str = "pctile_tile";
/// Detail of a tile: the halo's width (f64).
pub const D_HALO: &str = "pctile_halo_width";

/// Detail of an image cloud: its data window.
pub const DATA_WINDOW: &str = "exr_data_window";
/// Detail of an image cloud: its display window.
pub const DISPLAY_WINDOW: &str = "exr_display_window";
/// Point attribute of an image cloud: the point's pixel column.
pub const PIXEL_X: &str = "pixel_x";
/// Point attribute of an image cloud: the point's pixel row.
pub const PIXEL_Y: &str = "pixel_y";

/// Point attribute of a mesh read from a USD stage (uint): the mesh
/// prim's place in the detail [`D_USD_PRIMS`].
pub const USD_PRIM: &str = "usd_prim";
/// Point attribute of a mesh read from a USD stage (uint): the point of
/// that prim's `points` the vertex is (or is a copy of, for a corner).
pub const USD_POINT: &str = "usd_point";
/// Detail of a mesh read from a USD stage (str): its mesh prims, a line
/// each, `path count` (the prim's points).
pub const D_USD_PRIMS: &str = "usd_prims";
/// Detail of a mesh read from a USD stage at a time code (`--frame`,
/// double): that time code.
pub const D_USD_TIME: &str = "usd_time";
/// Custom attribute of a prim the USD writer makes: its `displayColor`
/// holds the cloud's colour bytes `red`, `green`, `blue`, which go out as
/// it alone (a float colour, where three `uchar` primvars are read by
/// Blender as signed bytes, 128-255 wrapped negative), and the reader
/// takes back as the same bytes.
pub const USD_COLOUR_BYTES: &str = "pcsss:colourBytes";

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
    ("illum_cos", "illum"),
    ("illum_diffuse", "illum (a constant dome, --indirect)"),
    ("thickness", "illum --thickness"),
    ("ssM", "ssmulti"),
    ("ssM_err", "ssmulti --method walk"),
    ("ssmulti_sd", "ssmulti"),
    ("ssmulti_rd", "ssmulti"),
    ("ssS", "sssingle"),
    ("beauty", "render"),
    (PIXEL_X, "render"),
    (PIXEL_Y, "render"),
    (DATA_WINDOW, "render"),
    (HALO, "pctile split"),
    (INDEX, "pctile split"),
    (D_HALO, "pctile split"),
];

/// The colours the stages make and read: 3-vectors with the colour role
/// (PLY writes them `NAME_r NAME_g NAME_b`, USD as `color3f`). A
/// 3-column array given to the Python module under one of these names is
/// a colour; `P` is a point and `N` a normal.
pub const COLOURS: &[&str] = &["Cd", "illum", "ssM", "ssS", "beauty", "Rd", "albedo"];

/// The stage that makes attribute `name`, if one does.
pub fn made_by(name: &str) -> Option<&'static str> {
    MAKERS.iter().find(|m| m.0 == name).map(|m| m.1)
}
