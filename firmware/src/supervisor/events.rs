//! The supervisor's event ring: mode changes, faults, resets and autotune results, newest last,
//! the oldest dropped when full. The console's `log` prints it.

use core::fmt;

use heapless::Deque;

use super::safety::Fault;
use crate::decimal::Fixed;
use crate::units::Millis;

/// Events kept.
pub const EVENT_CAPACITY: usize = 16;

/// What happened.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EventKind {
    /// The mode changed (names as `status` shows them).
    Mode {
        /// The mode left.
        from: &'static str,
        /// The mode entered.
        to: &'static str,
    },
    /// A fault was latched.
    Fault(Fault),
    /// A latched fault was cleared by `reset`.
    Cleared(Fault),
    /// An autotune finished and set the gains.
    Tuned {
        /// Ultimate gain, duty per K.
        ku_per_k: f32,
        /// Ultimate period, s.
        tu_s: f32,
    },
    /// An autotune gave up (the gains are unchanged).
    TuneAborted(&'static str),
    /// The large stepping ran its last phase.
    SteppingDone,
    /// Recovery held the column straight and started cooling it (springs still balanced).
    RecoveryCooling,
    /// A stepping's soak was done but a spring was still warm: it waits for the springs to rest.
    SpringsResting,
    /// A warning also printed on the console (`# warning: …`).
    Warning(Warning),
    /// A pose ended short of its target at this estimated bend, degrees, and why; standby.
    PoseOutOfReach {
        /// The estimated bend, degrees.
        deg: f32,
        /// Why.
        why: ShortBy,
    },
    /// A phase that waits for a temperature gave up (`soak`, `reheat`, `form` or `recover`,
    /// recovery's cooling) and the mode
    /// ended in standby; Tc when it did, K.
    TimedOut {
        /// Which wait.
        what: &'static str,
        /// Tc then, K.
        tc_k: f32,
    },
}

/// A line the console prints unasked, as `# {notice}` after the period's reply: a warning
/// (`# warning: …`) or the outcome of a command that finishes later (`# autotune done: …`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Notice {
    /// A warning (also in the `log`).
    Warning(Warning),
    /// An autotune finished: its measurement and the gains it put in use (in RAM).
    Tuned {
        /// Ultimate gain, duty per K.
        ku_per_k: f32,
        /// Ultimate period, s.
        tu_s: f32,
        /// The new proportional gain, duty per K.
        kp: f32,
        /// The new integral gain, duty per K·s.
        ki: f32,
        /// The new derivative gain, duty·s per K.
        kd: f32,
    },
    /// An autotune gave up (why); the gains are unchanged.
    TuneAborted(&'static str),
    /// A pose reached its target: the estimated bend and its standard deviation, degrees.
    PoseReached {
        /// The estimated bend, degrees.
        deg: f32,
        /// Its standard deviation, degrees.
        sd_deg: f32,
        /// With `form`: the bend it is formed to rest at, degrees (it was bent past it by the
        /// spring-back).
        rest_deg: Option<f32>,
    },
    /// A pose ended short of its target (also in the `log`).
    PoseOutOfReach {
        /// The estimated bend, degrees.
        deg: f32,
        /// Why.
        why: ShortBy,
    },
}

/// Why a pose ended short of its target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ShortBy {
    /// Every selected spring is austenite: they pull all they can.
    Austenite,
    /// The selected springs' measured power cannot make them austenite within the duty
    /// limit: what they reach with it, degrees, and their power's share of the model's.
    Power {
        /// The reach at that power, degrees.
        reach_deg: f32,
        /// The weakest selected spring's measured power over the model's.
        share: f32,
    },
    /// Steps gained nothing (no bend, no spring warmer or further transformed) over
    /// `steps` of them; the weakest selected spring's power share then.
    Stalled {
        /// Steps without a gain.
        steps: u8,
        /// The weakest selected spring's measured power over the model's.
        share: f32,
    },
}

impl fmt::Display for ShortBy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ShortBy::Austenite => f.write_str("the springs pull all they can"),
            ShortBy::Power { reach_deg, share } => write!(
                f,
                "the springs get {} % of their power, which reaches {} deg",
                Fixed::new(share * 100.0, 0),
                Fixed::new(reach_deg, 1)
            ),
            ShortBy::Stalled { steps, share } => write!(
                f,
                "{steps} steps gained nothing with the springs at {} % of their power",
                Fixed::new(share * 100.0, 0)
            ),
        }
    }
}

impl fmt::Display for Notice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Notice::Warning(w) => write!(f, "warning: {w}"),
            Notice::Tuned {
                ku_per_k,
                tu_s,
                kp,
                ki,
                kd,
            } => write!(
                f,
                "autotune done: ku={} tu={} kp={} ki={} kd={}; \
                 the gains are in use (in RAM): `save` keeps them",
                Fixed::new(ku_per_k, 4),
                Fixed::new(tu_s, 1),
                Fixed::new(kp, 3),
                Fixed::new(ki, 3),
                Fixed::new(kd, 3)
            ),
            Notice::TuneAborted(why) => {
                write!(f, "autotune aborted: {why}; the gains are unchanged")
            }
            Notice::PoseReached {
                deg,
                sd_deg,
                rest_deg: None,
            } => write!(
                f,
                "ok pose reached {}+-{}",
                Fixed::new(deg, 1),
                Fixed::new(sd_deg, 1)
            ),
            Notice::PoseReached {
                deg,
                sd_deg,
                rest_deg: Some(rest),
            } => write!(
                f,
                "ok pose reached {}+-{}; forming to rest at {}",
                Fixed::new(deg, 1),
                Fixed::new(sd_deg, 1),
                Fixed::new(rest, 1)
            ),
            Notice::PoseOutOfReach { deg, why } => {
                write!(f, "pose out of reach at {}: {why}", Fixed::new(deg, 1))
            }
        }
    }
}

/// A warning the console prints as `# warning: …` (its [`fmt::Display`]) and the `log` keeps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Warning {
    /// Frames unresolved for `unresolved_s` while heating: the loop holds the film region.
    Unresolved,
    /// Frames resolved again after a fallback.
    Resolved,
    /// The wall is not soft `soft_warn_s` into a soak, but the model says the heater can
    /// soften it: the soak goes on (up to `soak_timeout_s`).
    SoakSlow {
        /// The estimated frozen fraction now.
        frozen: f32,
        /// The inner layer's estimate now, K.
        inner_k: f32,
        /// The frozen fraction the heater can reach at best.
        best: f32,
        /// The estimated ambient, K.
        ambient_k: f32,
    },
    /// A spring's supply sagged under load: short of its current limit and below
    /// `spring_supply_min_v` (the power it delivers is measured, not assumed).
    SupplySag {
        /// Spring index, 0 = A.
        spring: u8,
        /// The supply's voltage under load, V.
        supply_v: f32,
        /// The current it gave, A.
        current_a: f32,
    },
    /// The board started after a reset that was not a power-up: every output off.
    Reset(super::boot::ResetCause),
    /// The frames show the lattice exposed unlike its configured design (another print,
    /// another view angle): MTTS now fits with what they show.
    ExposureUnlikeDesign {
        /// The exposed fraction the frames show, %.
        shows_pct: f32,
        /// The configured design's, %.
        design_pct: f32,
    },
    /// The frames show the configured design again.
    ExposureAsDesigned {
        /// The configured design's exposed fraction, %.
        design_pct: f32,
    },
    /// The wall cannot soften: even with the film held at its ceiling the model's steady
    /// state stays above `soft_frozen_max`. The soak ends.
    CannotSoften {
        /// The estimated frozen fraction now.
        frozen: f32,
        /// The frozen fraction the heater can reach at best.
        best: f32,
        /// The film's best steady temperature, K.
        film_k: f32,
        /// The estimated ambient, K.
        ambient_k: f32,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Warning::SupplySag {
                spring,
                supply_v,
                current_a,
            } => write!(
                f,
                "spring {} supply sags: {} V at {} A under load; its power is measured",
                crate::outputs::SPRING_NAMES[spring as usize % crate::outputs::SPRINGS],
                Fixed::new(supply_v, 2),
                Fixed::new(current_a, 1)
            ),
            Warning::Reset(cause) => write!(
                f,
                "reset by {}; every output off until a `mode` command",
                cause.name()
            ),
            Warning::ExposureUnlikeDesign {
                shows_pct,
                design_pct,
            } => write!(
                f,
                "lattice shows {} % exposed, its design {} %: fitting with what the image shows",
                Fixed::new(shows_pct, 0),
                Fixed::new(design_pct, 0)
            ),
            Warning::ExposureAsDesigned { design_pct } => write!(
                f,
                "lattice shows its design again ({} % exposed)",
                Fixed::new(design_pct, 0)
            ),
            Warning::Unresolved => f.write_str(
                "frames unresolved for unresolved_s while heating: the loop holds the film region",
            ),
            Warning::Resolved => {
                f.write_str("frames resolved again: the loop holds the mode's region")
            }
            Warning::SoakSlow {
                frozen,
                inner_k,
                best,
                ambient_k,
            } => write!(
                f,
                "wall still {} % frozen (inner layer {} K, ambient {} K); \
                 the heater can bring it to {} %: soaking on",
                Fixed::new(frozen * 100.0, 0),
                Fixed::new(inner_k, 1),
                Fixed::new(ambient_k, 1),
                Fixed::new(best * 100.0, 1)
            ),
            Warning::CannotSoften {
                frozen,
                best,
                film_k,
                ambient_k,
            } => write!(
                f,
                "wall cannot soften: {} % frozen, {} % at best with the film at {} K \
                 (ambient {} K): soak ended",
                Fixed::new(frozen * 100.0, 0),
                Fixed::new(best * 100.0, 0),
                Fixed::new(film_k, 1),
                Fixed::new(ambient_k, 1)
            ),
        }
    }
}

/// One event with its time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// When it happened.
    pub at: Millis,
    /// What happened.
    pub kind: EventKind,
}

/// The ring of recent events, with a count of all events ever pushed.
#[derive(Clone, Debug, Default)]
pub struct EventLog {
    ring: Deque<Event, EVENT_CAPACITY>,
    total: u32,
}

impl EventLog {
    /// Make an empty log.
    pub const fn new() -> Self {
        EventLog {
            ring: Deque::new(),
            total: 0,
        }
    }

    /// Add an event, dropping the oldest when full.
    pub fn push(&mut self, at: Millis, kind: EventKind) {
        if self.ring.is_full() {
            self.ring.pop_front();
        }
        // Cannot fail: a slot was just freed if needed.
        let _ = self.ring.push_back(Event { at, kind });
        self.total = self.total.wrapping_add(1);
    }

    /// Return the events kept, oldest first.
    pub fn iter(&self) -> impl Iterator<Item = &Event> {
        self.ring.iter()
    }

    /// Return how many events were ever pushed (so a reader can tell which are new).
    pub fn total(&self) -> u32 {
        self.total
    }

    /// Return the events pushed after the first `seen` of all time (at most the ring).
    pub fn since(&self, seen: u32) -> impl Iterator<Item = &Event> {
        let new = self.total.wrapping_sub(seen) as usize;
        let skip = self.ring.len().saturating_sub(new);
        self.ring.iter().skip(skip)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_drops_the_oldest_and_counts_everything() {
        let mut log = EventLog::new();
        for i in 0..20u64 {
            log.push(Millis(i), EventKind::SteppingDone);
        }
        assert_eq!(log.total(), 20);
        assert_eq!(log.iter().count(), EVENT_CAPACITY);
        assert_eq!(log.iter().next().unwrap().at, Millis(4));
        assert_eq!(log.since(18).count(), 2);
        assert_eq!(log.since(18).next().unwrap().at, Millis(18));
    }
}
