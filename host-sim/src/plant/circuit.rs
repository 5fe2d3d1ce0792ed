//! The spring channels' circuit: per spring, a supply (EMF, output resistance, current limit),
//! the spring power enable's high-side switch and the leads, the MOSFET, the low-side shunt and
//! the wire, whose resistance follows its phase and, weakly, its temperature; and the faults a
//! channel can have (a MOSFET failed short or open, an open wire, a wire bypassed).
//!
//! The supply's voltage is sensed at its output, ahead of the enable switch; the firmware's
//! [`thermorph::channels::FRONT_END`] subtracts the series resistance from that point to ground
//! (leads and switch, MOSFET, shunt: [`p::SERIES_OHM`]) from V/I to find the wire's. A supply in
//! its current limit runs in constant current: its output falls to what the load needs.
//!
//! The default channel has the same total resistance outside the wire as the plant had before
//! the circuit was modelled (`SPRING_LEAD_RESISTANCE_OHM`, 30 mΩ), split into the supply's
//! 10 mΩ and the 20 mΩ beyond its sense point, so the default block draws the same currents.

use super::params as p;
use super::sma;

/// What a channel's hardware is doing (a fault, or nothing).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChannelFaults {
    /// The MOSFET conducts whatever its gate (`Some(true)`: failed short), or never
    /// (`Some(false)`: failed open).
    pub mosfet_stuck: Option<bool>,
    /// The wire is open: no current can flow.
    pub open_wire: bool,
    /// The wire is bypassed: the channel's current flows around it.
    pub wire_short: bool,
}

/// One channel's state for a step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Flow {
    /// Current through the channel, A.
    pub current_a: f64,
    /// The supply's voltage at its sense point, V.
    pub supply_v: f64,
    /// Joule heat in the wire, W.
    pub wire_w: f64,
    /// Loss outside the wire (supply, switch, leads, MOSFET, shunt), W.
    pub lead_w: f64,
}

/// The wire's resistance at martensite fraction `xi` and temperature `t_k` with a temperature
/// coefficient `tempco_per_k` (0 for the fitted block), Ω.
pub fn wire_ohm(xi: f64, t_k: f64, tempco_per_k: f64) -> f64 {
    let r = sma::wire_resistance_ohm(xi);
    if t_k.is_finite() {
        r * (1.0 + tempco_per_k * (t_k - p::WIRE_REFERENCE_K))
    } else {
        r
    }
}

/// One channel with its own supply of EMF `emf_v`: the MOSFET's `gate`, the spring power
/// enable `power`, the wire at `wire_ohm`, and its `faults`.
pub fn channel(gate: bool, power: bool, wire_ohm: f64, emf_v: f64, faults: ChannelFaults) -> Flow {
    let conducts = faults.mosfet_stuck.unwrap_or(gate) && power && !faults.open_wire;
    if !conducts {
        return Flow {
            supply_v: emf_v,
            ..Flow::default()
        };
    }
    let wire = if faults.wire_short {
        p::BYPASSED_WIRE_OHM
    } else {
        wire_ohm
    };
    let load = p::SERIES_OHM + wire;
    let amps = (emf_v / (p::SUPPLY_OHM + load)).min(p::SPRING_SUPPLY_LIMIT_A);
    let supply_v = if amps >= p::SPRING_SUPPLY_LIMIT_A {
        amps * load
    } else {
        emf_v - amps * p::SUPPLY_OHM
    };
    let heated = if faults.wire_short { 0.0 } else { wire_ohm };
    Flow {
        current_a: amps,
        supply_v,
        wire_w: amps * amps * heated,
        lead_w: amps * amps * (p::SUPPLY_OHM + p::SERIES_OHM + (wire - heated)),
    }
}

/// The three channels: each its own supply of `emf_v`, or (`shared`) one supply feeding the
/// switched-on springs in parallel, folding back to its current limit for all of them.
pub fn channels(
    gates: [bool; 3],
    power: bool,
    wire_ohm: [f64; 3],
    emf_v: f64,
    shared: bool,
    faults: [ChannelFaults; 3],
) -> [Flow; 3] {
    if !shared {
        return core::array::from_fn(|i| channel(gates[i], power, wire_ohm[i], emf_v, faults[i]));
    }
    // Shared: the conducting branches in parallel behind one supply.
    let branch = |i: usize| {
        let f = faults[i];
        let conducts = f.mosfet_stuck.unwrap_or(gates[i]) && power && !f.open_wire;
        let wire = if f.wire_short {
            p::BYPASSED_WIRE_OHM
        } else {
            wire_ohm[i]
        };
        conducts.then_some(p::SERIES_OHM + wire)
    };
    let g_total: f64 = (0..3).filter_map(branch).map(|r| 1.0 / r).sum();
    if g_total == 0.0 {
        return [Flow {
            supply_v: emf_v,
            ..Flow::default()
        }; 3];
    }
    // Node voltage at the sense point: (E − V)/R_s = V·G, capped by the current limit.
    let v_free = emf_v / (1.0 + p::SUPPLY_OHM * g_total);
    let v = v_free.min(p::SPRING_SUPPLY_LIMIT_A / g_total);
    core::array::from_fn(|i| match branch(i) {
        None => Flow {
            supply_v: v,
            ..Flow::default()
        },
        Some(r) => {
            let amps = v / r;
            let heated = if faults[i].wire_short {
                0.0
            } else {
                wire_ohm[i]
            };
            Flow {
                current_a: amps,
                supply_v: v,
                wire_w: amps * amps * heated,
                lead_w: amps * amps * (r - heated),
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const OK: ChannelFaults = ChannelFaults {
        mosfet_stuck: None,
        open_wire: false,
        wire_short: false,
    };

    /// The default channel draws what the plant drew before the circuit was modelled:
    /// min(V / (R_wire + 30 mΩ), 15 A).
    #[test]
    fn the_default_channel_draws_what_the_lumped_lead_resistance_gave() {
        for xi in [0.0, 0.5, 1.0] {
            for emf in [3.5, 4.0, 5.0, 7.5] {
                let r = sma::wire_resistance_ohm(xi);
                let f = channel(true, true, r, emf, OK);
                let lumped = (emf / (r + p::SPRING_LEAD_RESISTANCE_OHM)).min(15.0);
                assert!((f.current_a - lumped).abs() < 1e-12, "{xi} {emf}");
                assert!((f.wire_w - lumped * lumped * r).abs() < 1e-9);
                // The sense point sees the load: V = I·(R_series + R_wire).
                assert!((f.supply_v - f.current_a * (p::SERIES_OHM + r)).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn power_enable_cuts_even_a_mosfet_failed_short() {
        let short = ChannelFaults {
            mosfet_stuck: Some(true),
            ..OK
        };
        assert!(channel(false, true, 0.3, 5.0, short).current_a > 14.0);
        let cut = channel(false, false, 0.3, 5.0, short);
        assert_eq!(cut.current_a, 0.0);
        assert_eq!(cut.supply_v, 5.0);
        let open = ChannelFaults {
            mosfet_stuck: Some(false),
            ..OK
        };
        assert_eq!(channel(true, true, 0.3, 5.0, open).current_a, 0.0);
        let wire = ChannelFaults {
            open_wire: true,
            ..OK
        };
        assert_eq!(channel(true, true, 0.3, 5.0, wire).current_a, 0.0);
    }

    #[test]
    fn a_bypassed_wire_draws_the_limit_and_heats_nothing() {
        let f = channel(
            true,
            true,
            0.3,
            5.0,
            ChannelFaults {
                wire_short: true,
                ..OK
            },
        );
        assert_eq!(f.current_a, p::SPRING_SUPPLY_LIMIT_A);
        assert_eq!(f.wire_w, 0.0);
        assert!(f.supply_v < 0.5, "{f:?}");
    }

    #[test]
    fn the_wire_warms_its_resistance_a_little() {
        let a = p::WIRE_TEMPCO_PER_K;
        let cold = wire_ohm(1.0, p::WIRE_REFERENCE_K, a);
        let hot = wire_ohm(1.0, p::WIRE_REFERENCE_K + 60.0, a);
        assert!((hot / cold - 1.018).abs() < 1e-9);
        // Small next to the phase change (+12.5 %).
        assert!(hot / cold - 1.0 < 0.2 * (wire_ohm(0.0, 298.15, a) / cold - 1.0));
        assert_eq!(wire_ohm(1.0, 400.0, 0.0), cold);
    }

    #[test]
    fn a_shared_supply_folds_back_to_its_limit() {
        let r = sma::wire_resistance_ohm(1.0);
        let f = channels([true, true, false], true, [r; 3], 5.0, true, [OK; 3]);
        assert!((f[0].current_a + f[1].current_a - 15.0).abs() < 1e-9);
        assert_eq!(f[2].current_a, 0.0);
        let one = channels([true, false, false], true, [r; 3], 5.0, true, [OK; 3]);
        assert!((one[0].current_a - 15.0).abs() < 1e-9);
    }
}
