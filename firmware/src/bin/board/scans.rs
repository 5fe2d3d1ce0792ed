//! The spring channels' ADC scans as the library reads them: the pure part of `sense` (no
//! hardware), so the host tests can check it.
//!
//! A scan is [`INPUTS`] counts in the ADC's sequence order — the currents of springs A, B, C,
//! then their supplies — the layout of [`Counts`]. A control period's scans (oldest first) give
//! its [`SpringSense`]: the scans taken too soon after a gate or the spring power switched are
//! dropped ([`Settle`]), the rest split into a first and a second half in time, each averaged.

use thermorph::channels::{Counts, SpringSense};
use thermorph::outputs::SPRINGS;

/// Counts in one scan: a current and a supply per spring.
pub const INPUTS: usize = 2 * SPRINGS;

/// Scans dropped after a switch: those that may have started within [`SETTLE_US`] of it, when
/// a scan takes `scan_ns` — the scan under way at the switch included, whose later inputs were
/// converted after it (`settle_scans(200, 262_400)` is 2).
///
/// [`SETTLE_US`]: thermorph::channels::SETTLE_US
pub const fn settle_scans(settle_us: u32, scan_ns: u32) -> usize {
    (settle_us as u64 * 1_000).div_ceil(scan_ns as u64) as usize + 1
}

/// The scans still to drop before the channels read the outputs as applied.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Settle {
    left: usize,
}

impl Settle {
    /// Nothing to drop.
    pub const fn new() -> Self {
        Settle { left: 0 }
    }

    /// The outputs switched: drop the next `scans` scans (the ones before the switch are gone).
    pub fn switched(&mut self, scans: usize) {
        self.left = scans;
    }

    /// Return the scans still to drop.
    pub fn left(&self) -> usize {
        self.left
    }

    /// The control period's reading from `counts`, its new scans (whole scans, oldest first):
    /// the scans still to drop are dropped first, then the rest must be at least two scans.
    pub fn sense(&mut self, counts: &[u16]) -> Option<SpringSense> {
        let scans = counts.len() / INPUTS;
        let drop = self.left.min(scans);
        self.left -= drop;
        let kept = &counts[drop * INPUTS..scans * INPUTS];
        let n = kept.len() / INPUTS;
        if n < 2 {
            return None;
        }
        let (first, second) = kept.split_at(n / 2 * INPUTS);
        Some(SpringSense {
            samples: [mean(first), mean(second)],
        })
    }
}

/// One scan's counts.
pub fn scan(counts: &[u16]) -> Counts {
    let mut c = Counts::default();
    c.current.copy_from_slice(&counts[..SPRINGS]);
    c.supply.copy_from_slice(&counts[SPRINGS..INPUTS]);
    c
}

/// The mean of each input over `counts` (whole scans, at least one), rounded to the nearest count.
fn mean(counts: &[u16]) -> Counts {
    let n = (counts.len() / INPUTS) as u32;
    let mut sum = [0u32; INPUTS];
    for s in counts.chunks_exact(INPUTS) {
        for (t, &c) in sum.iter_mut().zip(s) {
            *t += u32::from(c);
        }
    }
    let mut m = [0u16; INPUTS];
    for (m, t) in m.iter_mut().zip(sum) {
        // At most 65 535 · n / n.
        *m = ((t + n / 2) / n) as u16;
    }
    scan(&m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    /// `n` scans, scan `k` reading `base + k` on every input but supply C, which reads `k * 10`.
    fn scans(n: usize, base: u16) -> Vec<u16> {
        (0..n as u16)
            .flat_map(|k| [base + k, base + k, base + k, base + k, base + k, k * 10])
            .collect()
    }

    #[test]
    fn the_order_of_a_scan_is_the_counts_layout() {
        let c = scan(&[1, 2, 3, 4, 5, 6]);
        assert_eq!(c.current, [1, 2, 3]);
        assert_eq!(c.supply, [4, 5, 6]);
    }

    #[test]
    fn the_halves_are_means_in_time_order() {
        let mut s = Settle::new();
        // Scans 0..4 then 4..8 (four each): means 1.5 → 2 (rounded) and 5.5 → 6.
        let sense = s.sense(&scans(8, 0)).expect("eight scans");
        assert_eq!(sense.samples[0].current, [2; 3]);
        assert_eq!(sense.samples[1].current, [6; 3]);
        assert_eq!(sense.samples[0].supply, [2, 2, 15]);
        assert_eq!(sense.samples[1].supply, [6, 6, 55]);
        // An odd count: the second half takes the extra scan (0 | 1, 2).
        let sense = s.sense(&scans(3, 100)).expect("three scans");
        assert_eq!(sense.samples[0].current, [100; 3]);
        assert_eq!(sense.samples[1].current, [102; 3]);
    }

    #[test]
    fn fewer_than_two_scans_give_nothing() {
        let mut s = Settle::new();
        assert_eq!(s.sense(&[]), None);
        assert_eq!(s.sense(&scans(1, 7)), None);
        // A partial scan is ignored.
        assert_eq!(s.sense(&scans(2, 7)[..INPUTS + 3]), None);
        assert!(s.sense(&scans(2, 7)).is_some());
    }

    #[test]
    fn scans_after_a_switch_are_dropped_across_periods() {
        let mut s = Settle::new();
        s.switched(3);
        // Two scans come: both dropped, one more to drop.
        assert_eq!(s.sense(&scans(2, 0)), None);
        assert_eq!(s.left(), 1);
        // Five come: the first dropped, 1 2 | 3 4 kept.
        let sense = s.sense(&scans(5, 0)).expect("four kept");
        assert_eq!(sense.samples[0].current, [2; 3]); // (1 + 2) / 2 = 1.5 → 2
        assert_eq!(sense.samples[1].current, [4; 3]); // (3 + 4) / 2 = 3.5 → 4
        assert_eq!(s.left(), 0);
        // A new switch starts the count again.
        s.switched(2);
        assert_eq!(s.sense(&scans(3, 0)), None);
        assert_eq!(s.left(), 0);
    }

    #[test]
    fn the_settle_covers_the_scan_under_way() {
        // 200 µs of 262.4 µs scans: the scan under way at the switch and the next.
        assert_eq!(settle_scans(200, 262_400), 2);
        // Scans of 100 µs: two within the 200 µs, and the one under way.
        assert_eq!(settle_scans(200, 100_000), 3);
        assert_eq!(settle_scans(0, 100_000), 1);
    }

    #[test]
    fn full_scale_counts_do_not_overflow() {
        let counts = [4095u16; INPUTS * 256];
        let sense = Settle::new().sense(&counts).expect("256 scans");
        assert_eq!(sense.samples, [scan(&[4095; INPUTS]); 2]);
        // Counts beyond 12 bits (a broken reading) are averaged as they are, for the library
        // to refuse.
        let counts = [u16::MAX; INPUTS * 2];
        let sense = Settle::new().sense(&counts).expect("two scans");
        assert_eq!(sense.samples[0].current, [u16::MAX; 3]);
    }
}
