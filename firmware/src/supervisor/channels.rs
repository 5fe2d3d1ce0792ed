//! The spring channels in the supervisor: each period's readings judged against the outputs
//! they were taken under, a fault latched (which cuts the spring power in the same decision), a
//! sagging supply reported, and `reset`'s probe of every channel.
//!
//! `reset` may clear a fault only when no channel conducts with its gate off; the spring power
//! is off while a fault is latched, so nothing could be seen. With a board that senses its
//! springs, `reset` (once every other cause is gone) asks for a probe ([`Decision::probe`]):
//! the caller turns the spring power on with every gate off, reads the channels once they have
//! settled and hands the reading to [`Supervisor::finish_probe`], which clears the fault or
//! refuses with the channel that conducts. A stuck MOSFET is powered for that one reading
//! only (a few ms).

use super::Supervisor;
use super::events::{EventKind, Notice, Warning};
use super::report::Reply;
use super::safety::Fault;
use crate::channels::{Channels, Probe, SpringSense};
use crate::outputs::{Outputs, SPRING_NAMES, SPRINGS};
use crate::units::Millis;

/// A sagging supply is reported at most this often, ms.
pub const SAG_WARN_EVERY_MS: u64 = 60_000;

impl Supervisor {
    /// The spring channels' readings of this control period (taken while the last decision's
    /// outputs were applied): the next [`Supervisor::step`] judges them. The board and the
    /// simulator call it once a period, before the period's steps.
    pub fn sense_springs(&mut self, sense: &SpringSense) {
        self.sense = Some(*sense);
    }

    /// Return the spring channels as measured.
    pub fn channels(&self) -> &Channels {
        &self.channels
    }

    /// Put the boot calibration of the channels in use (the board's, before the first step).
    pub fn set_channels(&mut self, channels: Channels) {
        self.channels = channels;
    }

    /// Judge `sense`, read while `ran` was applied: latch a channel's fault, report a sag.
    pub(super) fn check_channels(&mut self, now: Millis, sense: &SpringSense, ran: Outputs) {
        let (fault, sag) =
            self.channels
                .update(sense, ran.springs, ran.spring_power, &self.settings);
        if let Some(f) = fault {
            self.latch(now, Fault::Channel(f));
        }
        let due = self
            .sag_warned
            .is_none_or(|t| now.0 >= t.0 + SAG_WARN_EVERY_MS);
        if let Some(g) = sag.filter(|_| due && self.fault.is_none()) {
            self.sag_warned = Some(now);
            let w = Warning::SupplySag {
                spring: g.spring,
                supply_v: g.supply_v,
                current_a: g.current_a,
            };
            self.events.push(now, EventKind::Warning(w));
            self.notice = Some(Notice::Warning(w));
        }
    }

    /// Finish `reset`'s probe with the channels' reading `sense` (spring power on, every gate
    /// off) at `now`: clear the fault when no channel conducts, else refuse naming it. The
    /// spring power is off again in the outputs from now on ([`Supervisor::outputs`]).
    pub fn finish_probe(&mut self, now: Millis, sense: &SpringSense) -> Reply {
        if !core::mem::take(&mut self.probe_pending) {
            return Reply::err("bad-state", "no probe was asked for");
        }
        // The fault is still latched: its safe outputs (spring power, gates and heater off),
        // until `clear_fault` leaves every output off.
        self.outputs = self.safe_outputs();
        match self.channels.probe(sense, &self.settings) {
            Probe::Conducts(i, amps) => Reply::conducting(SPRING_NAMES[i as usize % SPRINGS], amps),
            Probe::Garbage(i) => Reply::unreadable(SPRING_NAMES[i as usize % SPRINGS]),
            Probe::Clear => self.clear_fault(now),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{ModeId, SpringMemory};
    use super::*;
    use crate::channels::{Channels, Counts};
    use crate::command::parse;
    use crate::measurement::{Measurement, Quality};
    use crate::outputs::{SPRINGS, SpringMask};
    use crate::settings::Settings;
    use crate::supervisor::Decision;
    use crate::units::Kelvin;

    /// What each channel does electrically in these tests.
    #[derive(Clone, Copy, PartialEq)]
    enum Hw {
        Ok,
        /// The MOSFET conducts whatever its gate.
        Shorted,
        /// Nothing flows.
        Open,
        /// The wire is bypassed.
        Bypassed,
    }

    /// The counts a channel reads under `o`: 15 A through a 0.27 Ω wire while it conducts, a
    /// 5 V supply.
    fn sense(o: &Outputs, hw: [Hw; SPRINGS]) -> SpringSense {
        let counts = Counts {
            current: [0, 1, 2].map(|i| amps(o, hw[i], i).0),
            supply: [0, 1, 2].map(|i| amps(o, hw[i], i).1),
        };
        SpringSense {
            samples: [counts; 2],
        }
    }

    fn amps(o: &Outputs, hw: Hw, i: usize) -> (u16, u16) {
        let conducts = o.spring_power
            && match hw {
                Hw::Ok | Hw::Bypassed => o.springs.contains(i),
                Hw::Shorted => true,
                Hw::Open => false,
            };
        let wire = if hw == Hw::Bypassed { 0.005 } else { 0.27 };
        if conducts {
            Channels::ideal_counts(15.0, 15.0 * (0.02 + wire))
        } else {
            Channels::ideal_counts(0.0, 5.0)
        }
    }

    fn frame(at_ms: u64, seq: u32) -> Measurement {
        Measurement {
            at: Millis(at_ms),
            seq,
            regions: [330.0, 325.0, 325.0, 300.0, 298.0].map(Kelvin::new),
            hottest: Kelvin::new(330.0),
            filled_pixels: 0,
            quality: Quality::Resolved,
            bound: Kelvin::lit(0.5),
            tilt: None,
            exposure: None,
        }
    }

    /// A supervisor with its channels sensed, stepped every 50 ms with a frame every 250 ms.
    struct Bench {
        sup: Supervisor,
        now_ms: u64,
        seq: u32,
        hw: [Hw; SPRINGS],
    }

    impl Bench {
        fn new() -> Bench {
            let mut sup =
                Supervisor::with_memory(Millis(0), Settings::DEFAULT, SpringMemory::RESTED);
            sup.set_channels(Channels::default());
            Bench {
                sup,
                now_ms: 0,
                seq: 0,
                hw: [Hw::Ok; SPRINGS],
            }
        }

        /// One 50 ms period: the channels as the last outputs drove them, a frame every fifth.
        fn period(&mut self, line: Option<&str>) -> Decision {
            self.now_ms += 50;
            let s = sense(&self.sup.outputs(), self.hw);
            self.sup.sense_springs(&s);
            self.seq += 1;
            let m = self
                .seq
                .is_multiple_of(5)
                .then(|| frame(self.now_ms, self.seq));
            let now = Millis(self.now_ms);
            let d = self.sup.step(now, m.as_ref(), None);
            match line {
                Some(l) => self.sup.step(now, None, Some(parse(l).unwrap())),
                None => d,
            }
        }

        fn run(&mut self, periods: u32) -> Decision {
            let mut d = self.period(None);
            for _ in 1..periods {
                d = self.period(None);
            }
            d
        }
    }

    #[test]
    fn power_is_on_only_while_a_mode_wants_the_springs() {
        let mut b = Bench::new();
        assert!(!b.run(4).outputs.spring_power, "standby");
        assert!(b.period(Some("mode step-small A")).outputs.spring_power);
        assert!(!b.period(Some("mode form")).outputs.spring_power);
        assert!(b.period(Some("mode recover")).outputs.spring_power);
        assert!(!b.period(Some("stop")).outputs.spring_power);
    }

    /// A MOSFET that fails short while a mode has the power on, its gate off: latched within
    /// one control period of the two samples, the spring power and every gate and the heater
    /// off in that same decision.
    #[test]
    fn a_mosfet_failed_short_is_cut_within_one_period() {
        let mut b = Bench::new();
        b.run(4);
        b.period(Some("mode step-small B"));
        let d = b.run(4);
        assert!(
            d.outputs.spring_power && !d.outputs.springs.contains(1),
            "soaking"
        );
        b.hw[1] = Hw::Shorted;
        let d = b.period(None);
        assert_eq!(b.sup.fault().map(|f| f.code()), Some("spring-stuck-on"));
        assert!(!d.outputs.spring_power && d.outputs.springs.is_empty());
        assert_eq!(d.outputs.heater.fraction(), 0.0);
        let reason = std::format!("{}", b.sup.fault().unwrap().reason());
        assert!(
            reason.starts_with("spring B stuck on: 15.0 A with its gate off"),
            "{reason}"
        );
    }

    /// `reset` probes the channels: refused while the shorted MOSFET still conducts (the
    /// probe's only power-on), accepted once it is gone; nothing heats after either.
    #[test]
    fn reset_probes_the_channels_and_refuses_while_one_conducts() {
        let mut b = Bench::new();
        b.period(Some("mode step-small A"));
        b.run(4);
        b.hw[0] = Hw::Shorted;
        b.run(2);
        assert_eq!(b.sup.fault().map(|f| f.code()), Some("spring-stuck-on"));
        let d = b.period(Some("reset"));
        assert!(d.probe && d.reply.is_none());
        assert!(d.outputs.spring_power && d.outputs.springs.is_empty());
        assert_eq!(d.outputs.heater.fraction(), 0.0);
        let r = b
            .sup
            .finish_probe(Millis(b.now_ms), &sense(&d.outputs, b.hw));
        assert_eq!(
            r.as_str(),
            "err cause-present: spring A conducts 15.0 A with its gate off"
        );
        assert!(b.sup.fault().is_some());
        assert!(
            !b.period(None).outputs.spring_power,
            "the probe's power is off again"
        );
        // A probe not carried out is void: its reply comes from nowhere else.
        let d = b.period(Some("reset"));
        assert!(d.probe);
        b.period(None);
        let r = b
            .sup
            .finish_probe(Millis(b.now_ms), &sense(&d.outputs, b.hw));
        assert!(r.as_str().starts_with("err bad-state"), "{r:?}");
        // The MOSFET replaced: the probe finds nothing, the fault clears to stopped.
        b.hw[0] = Hw::Ok;
        let d = b.period(Some("reset"));
        let r = b
            .sup
            .finish_probe(Millis(b.now_ms), &sense(&d.outputs, b.hw));
        assert!(r.is_ok(), "{r:?}");
        assert_eq!(b.sup.mode().id(), ModeId::Stopped);
        assert_eq!(b.period(None).outputs, Outputs::OFF);
    }

    #[test]
    fn an_open_spring_is_named() {
        let mut b = Bench::new();
        b.hw[2] = Hw::Open;
        b.period(Some("mode recover"));
        let d = b.run(4);
        assert_eq!(b.sup.fault().map(|f| f.code()), Some("spring-open"));
        assert!(!d.outputs.spring_power);
        let reason = std::format!("{}", b.sup.fault().unwrap().reason());
        assert_eq!(
            reason,
            "spring C open: 0.0 A with its gate on (supply 5.0 V)"
        );
    }

    #[test]
    fn a_bypassed_wire_or_an_over_current_is_cut_at_once() {
        let mut b = Bench::new();
        b.hw[0] = Hw::Bypassed;
        b.period(Some("mode recover"));
        b.period(None);
        assert_eq!(b.sup.fault().map(|f| f.code()), Some("spring-short"));
        // Over-current: one sample above spring_short_a is enough.
        let mut c = Channels::default();
        let s = Settings::DEFAULT;
        let (hi, v) = Channels::ideal_counts(25.0, 4.0);
        let (lo, _) = Channels::ideal_counts(0.0, 5.0);
        let sense = SpringSense {
            samples: [
                Counts {
                    current: [lo, lo, lo],
                    supply: [v; 3],
                },
                Counts {
                    current: [lo, hi, lo],
                    supply: [v; 3],
                },
            ],
        };
        let (f, _) = c.update(&sense, SpringMask::from_bits(0b010), true, &s);
        assert!(matches!(
            f,
            Some(crate::channels::ChannelFault::Short { spring: 1, .. })
        ));
    }

    #[test]
    fn a_sagging_supply_is_reported_once_a_minute() {
        let mut b = Bench::new();
        b.period(Some("mode recover"));
        let mut notices = 0;
        for _ in 0..(2 * 60 * 20) {
            b.now_ms += 50;
            let o = b.sup.outputs();
            let c = |i: usize| {
                if o.spring_power && o.springs.contains(i) {
                    Channels::ideal_counts(11.0, 3.4)
                } else {
                    Channels::ideal_counts(0.0, 3.5)
                }
            };
            b.sup.sense_springs(&SpringSense {
                samples: [Counts {
                    current: [0, 1, 2].map(|i| c(i).0),
                    supply: [0, 1, 2].map(|i| c(i).1),
                }; 2],
            });
            b.seq += 1;
            let m = frame(b.now_ms, b.seq);
            let d = b.sup.step(Millis(b.now_ms), Some(&m), None);
            if let Some(Notice::Warning(Warning::SupplySag { supply_v, .. })) = d.notice {
                assert!((supply_v - 3.4).abs() < 0.01);
                notices += 1;
            }
            if b.sup.fault().is_some() || !o.spring_power {
                break;
            }
        }
        assert!(notices >= 1, "{notices}");
        let text = std::format!(
            "{}",
            Warning::SupplySag {
                spring: 1,
                supply_v: 3.4,
                current_a: 11.0
            }
        );
        assert_eq!(
            text,
            "spring B supply sags: 3.40 V at 11.0 A under load; its power is measured"
        );
    }

    /// SPEC 5: while a fault is latched `set` may tighten a limit but never relax one, and
    /// `load` and `defaults` apply no record that relaxes one.
    #[test]
    fn a_latched_fault_lets_limits_be_tightened_never_relaxed() {
        let mut b = Bench::new();
        b.period(Some("estop"));
        for line in [
            "set t_max_k 383",
            "set runaway_duty_pct 100",
            "set runaway_window_s 120",
            "set no_response_s 600",
            "set spring_leak_a 2",
            "set runaway_gain_k 0.5",
        ] {
            let r = b.period(Some(line)).reply.unwrap();
            assert!(r.as_str().starts_with("err bad-state"), "{line}: {r:?}");
        }
        assert_eq!(b.sup.settings(), &Settings::DEFAULT);
        for line in ["set t_max_k 370", "set no_response_s 30", "set kp 0.2"] {
            let r = b.period(Some(line)).reply.unwrap();
            assert!(r.is_ok(), "{line}: {r:?}");
        }
        // `defaults` would put t_max_k back up to 373: refused while latched.
        let r = b.period(Some("defaults")).reply.unwrap();
        assert!(r.as_str().contains("t_max_k would be relaxed"), "{r:?}");
        // A stored record with the default limits: refused as well.
        let d = b.period(Some("load"));
        assert!(d.store.is_some());
        let rec = Settings::DEFAULT.encode();
        let r = b.sup.finish_store(
            Millis(b.now_ms),
            crate::supervisor::store::StoreOutcome::Loaded(Some(&rec)),
        );
        assert!(r.as_str().starts_with("err bad-state"), "{r:?}");
        assert_eq!(b.sup.settings().t_max_k, 370.0);
    }
}
