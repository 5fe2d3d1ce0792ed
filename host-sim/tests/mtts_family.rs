//! MTTS on the scene family (unseen seeds): never a swap, never NaN, a merged or fallback frame
//! says so, and resolved frames at periods ≥ 5 px are accurate.

use host_sim::imaging::mtts_wp::family_outcomes;
use host_sim::imaging::view_family::UNSEEN;
use thermorph::mtts::Quality;

#[test]
fn unseen_members_never_swap_and_resolved_ones_are_accurate() {
    let outs = family_outcomes(UNSEEN, 60, true);
    assert_eq!(outs.iter().filter(|o| o.swapped).count(), 0, "swaps");
    for o in &outs {
        assert!(o.err_k.iter().all(|e| e.is_finite()), "{o:?}");
        assert!(o.bound_k.is_finite() && o.bound_k >= 0.0);
    }
    // Resolved frames at periods ≥ 5 px: mean error within 0.5 K.
    let sel: Vec<_> = outs
        .iter()
        .filter(|o| o.quality == Quality::Resolved && o.period_px >= 5.0)
        .collect();
    assert!(sel.len() >= 15, "{} resolved frames", sel.len());
    let mean = sel.iter().map(|o| o.err_k[0] + o.err_k[1]).sum::<f64>() / (2.0 * sel.len() as f64);
    assert!(mean <= 0.5, "mean error {mean:.2} K");
    // A gap far under the lattice's detection threshold is never reported as resolved.
    for o in outs.iter().filter(|o| o.gap_k.abs() < 0.3) {
        assert_ne!(o.quality, Quality::Resolved, "{o:?}");
    }
}
