//! Static benchmarks: Timoshenko cantilever, the roll-up of a beam into a circle.

use std::f64::consts::PI;

use crate::solve_static;

use super::common::*;

#[test]
fn small_tip_load_matches_timoshenko_theory() {
    let (_, gak, ei) = aluminium();
    let (l, p): (f64, f64) = (0.8, 1.0);
    let exact = p * l.powi(3) / (3.0 * ei) + p * l / gak;
    for m in [1, 4] {
        let model = model(&static_scene(&cantilever(
            l,
            m,
            "[[loads]]\nnode = \"b\"\nforce = [0.0, -1.0]\n",
        )));
        let sol =
            solve_static(&model, model.densities(None).unwrap(), &static_settings(1)).unwrap();
        let tip = model.node_index("b").unwrap();
        let v = -sol.q[3 * tip + 1];
        assert!(
            (v / exact - 1.0).abs() < 1e-3,
            "m = {m}: {v:.6e} vs Timoshenko {exact:.6e}"
        );
    }
}

/// Nodal positions of a cantilever under end moment `M = k·2πEI/L`, with the exact arc.
fn roll_up(m: usize, fraction: f64) -> (f64, f64) {
    let (_, _, ei) = aluminium();
    let l = 1.0;
    let moment = fraction * 2.0 * PI * ei / l;
    let model = model(&static_scene(&cantilever(
        l,
        m,
        &format!("[[loads]]\nnode = \"b\"\nmoment = {moment:e}\n"),
    )));
    let sol = solve_static(
        &model,
        model.densities(None).unwrap(),
        &static_settings(4 * m),
    )
    .unwrap();
    let radius = l / (2.0 * PI * fraction);
    let exact = |s: f64| {
        [
            radius * (s / radius).sin(),
            radius * (1.0 - (s / radius).cos()),
        ]
    };
    let error_at = |node: usize| {
        let p = model.nodes[node].position;
        let e = exact(p.x);
        ((p.x + sol.q[3 * node] - e[0]).powi(2) + (p.y + sol.q[3 * node + 1] - e[1]).powi(2)).sqrt()
    };
    let tip = error_at(model.node_index("b").unwrap());
    let worst = (0..model.nodes.len()).map(error_at).fold(0.0, f64::max);
    (tip / l, worst / l)
}

#[test]
fn end_moment_rolls_a_cantilever_into_a_circle() {
    let (tip16, _) = roll_up(16, 1.0);
    assert!(tip16 <= 1e-3, "tip error {tip16:.2e} L with 16 elements");
    // Along the beam the discrete shape converges to the circle at second order.
    let ms = [4, 8, 16, 32];
    let worst: Vec<f64> = ms.iter().map(|&m| roll_up(m, 1.0).1).collect();
    for w in worst.windows(2) {
        assert!(w[1] < w[0], "error must fall with refinement: {worst:?}");
    }
    let order = -log_slope(&ms.map(|m| m as f64), &worst);
    assert!(
        (order - 2.0).abs() < 0.15,
        "order {order:.2}, errors {worst:?}"
    );
    // So does the tip of a half circle.
    let half: Vec<f64> = ms.iter().map(|&m| roll_up(m, 0.5).0).collect();
    assert!(
        half.windows(2).all(|w| w[1] < w[0]) && half[2] < 1e-2,
        "{half:?}"
    );
}
