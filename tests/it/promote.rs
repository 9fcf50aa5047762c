//! promote: ptarea sums to Tarea after the chain, for every estimate.

use crate::util::*;
use pcsss::stages::scatter::PtareaMode;
use pcsss::stages::{measure, promote};

#[test]
fn after_the_chain_ptarea_sums_to_tarea_for_every_mode() {
    for mode in [
        PtareaMode::Prim,
        PtareaMode::Knn,
        PtareaMode::Voronoi,
        PtareaMode::Centroid,
    ] {
        let mut mesh = uv_sphere(16, 32, 2.0, [1e6, -1e6, 1e6]);
        measure::measure(&mut mesh).unwrap();
        promote::promote(
            &mut mesh,
            promote::Class::Face,
            "area",
            promote::Method::Sum,
            "Tarea",
        )
        .unwrap();
        let mut c = scatter_n(&mesh, 5000, 1, mode);
        assert_eq!(
            c.detail_f64("Tarea").unwrap(),
            mesh.detail_f64("Tarea").unwrap(),
            "detail inherited"
        );
        promote::normalize(&mut c).unwrap();
        let tarea = c.detail_f64("Tarea").unwrap();
        let sum: f64 = c.points().scalar_f64("ptarea").unwrap().iter().sum();
        assert!(
            ((sum - tarea) / tarea).abs() < 1e-6,
            "{mode:?}: {sum} vs {tarea}"
        );
        assert!(((c.detail_f64("Tptarea").unwrap() - tarea) / tarea).abs() < 1e-6);
    }
}

#[test]
fn prim_ptarea_sums_to_the_area_before_normalising() {
    let c = scatter_n(&cube(), 1000, 5, PtareaMode::Prim);
    let sum: f64 = c.points().scalar_f64("ptarea").unwrap().iter().sum();
    assert!((sum - 6.0).abs() < 1e-5, "{sum}");
}
