//! Posture control, `mode pose ANGLE [SPRINGS] [form]`: bend the column to ANGLE degrees from
//! straight by the bend estimate ([`crate::posture`]), from whatever posture it is in.
//!
//! It heats as stepping does (ready by softness: the soak), then drives the selected springs
//! in short steps, each followed by a settle with the springs off, so the estimate sees what
//! the step did before the next. A step lasts `POSE_S_PER_DEG` per degree still missing
//! (at least [`MIN_STEP_S`], at most `step_s`): the steps shrink as the bend nears the
//! target. Within `pose_tol_deg` after a settle the target is reached (`# pose reached
//! ANGLE+-U`, a notice, unlogged: the console is ASCII); the mode then holds `hot_k` with the springs off, stepping again if the bend
//! sags out of the tolerance, until `hold_timeout_s` — or, with `form`, it forms at once
//! (phase `cool`), still stepping the springs while the bend sags below its aim and the wall
//! is soft enough to take it, and ends in standby. A formed pose aims past the target by the
//! spring-back the frozen wall shows once the springs rest
//! ([`crate::posture::Posture::form_aim_deg`]), so that it rests at the target.
//!
//! A target below the present bend is reached by partial recovery, not by the opposite
//! springs: with the wall soft the SMP's memory pulls the column back towards straight by
//! itself (a formed bend is released as the wall softens in the soak), while the opposite
//! springs would pull through the straight posture into the other plane and fight the
//! selected ones still austenite. So above the tolerance the mode waits with the springs off;
//! once below, it steps. A target the selected springs cannot reach (fully austenite against
//! the soft wall, [`crate::posture::Posture::reach_deg`]) is refused by the command; a step
//! that finds every selected spring austenite and the bend still short ends the mode in
//! standby with `# pose out of reach at …`.

use super::events::{EventKind, Notice, ShortBy};
use super::mode::{Ctx, Drive, Mode, ModeStep, Next, Soak, ms};
use crate::fmath::clamp;
use crate::observer::{Estimate, SpringParams, attainable_austenite};
use crate::outputs::{SPRINGS, SpringMask};
use crate::posture::Posture;
use crate::settings::Settings;
use crate::units::Millis;

/// Step length per degree still missing, s/°.
pub const POSE_S_PER_DEG: f32 = 0.25;
/// The shortest step, s.
pub const MIN_STEP_S: f32 = 0.5;
/// Settle after a step (springs off) before the bend is judged, s.
pub const SETTLE_S: f32 = 3.0;
/// A selected spring counts as fully pulling above this austenite fraction.
pub const FULL_AUSTENITE: f32 = 0.97;
/// While forming, the springs step only while the wall's frozen fraction is below this: a
/// wall this frozen has locked the bend.
pub const FORM_STEP_FROZEN_MAX: f32 = 0.5;
/// The springs' total on-time while forming, at most, s: forming's cooling loses a few degrees
/// as the springs cool, which a few seconds of steps make up; at steep tilts the camera reads
/// the cooling column short (docs/posture.md), and unbounded steps would chase that.
pub const FORM_STEP_BUDGET_S: f32 = 3.0;
/// The highest target, degrees.
pub const MAX_TARGET_DEG: f32 = 65.0;
/// The shortest share of the model's power a step is lengthened for: a weaker supply gets
/// steps this much longer at most (up to `step_s`).
pub const MIN_STEP_SHARE: f32 = 0.25;
/// Steps that gain nothing — the bend up by [`GAIN_DEG`], a selected spring warmer by
/// [`GAIN_K`] or further transformed by [`GAIN_AUSTENITE`] since the last gain — before the
/// pose ends short (a supply that gives each step only what the settle loses).
pub const MAX_STALLED_STEPS: u8 = 10;
/// A gain in the bend, degrees.
pub const GAIN_DEG: f32 = 0.5;
/// A gain in a selected spring's estimated temperature, K.
pub const GAIN_K: f32 = 1.0;
/// A gain in a selected spring's estimated austenite fraction.
pub const GAIN_AUSTENITE: f32 = 0.02;

/// Where a pose is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PosePhase {
    /// Heating until the wall is soft (as stepping's soak).
    Soak {
        /// The `soft_warn_s` warning has been given.
        warned: bool,
    },
    /// The selected springs on (in their temperature band); time left, ms.
    Step {
        /// Time left, ms.
        left_ms: u32,
    },
    /// Springs off while the bend settles; time left, ms.
    Settle {
        /// Time left, ms.
        left_ms: u32,
    },
    /// Reached: holding `hot_k`, the springs off, stepping again if the bend sags.
    Hold,
    /// Reached with `form`: cooling as forming does (heater off, fan `form_fan`) until the
    /// hotter target is at `form_end_k`, the springs stepping on whenever the bend sags below
    /// the target while the wall is still soft enough to take it (the bend forming would
    /// otherwise lose as the springs cool).
    Form {
        /// When the cooling started (its `form_timeout_s` counts from here).
        since: Millis,
        /// The springs are on in this window.
        on: bool,
        /// Time left in the window, ms.
        left_ms: u32,
        /// What is left of [`FORM_STEP_BUDGET_S`], ms.
        budget_ms: u32,
    },
}

/// A pose's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Posing {
    /// The target bend, degrees.
    pub target_deg: f32,
    /// The bend the pose bends to, degrees: the target, or with `form` the target plus the
    /// spring-back the formed wall will show once the springs rest
    /// ([`crate::posture::Posture::form_aim_deg`]).
    pub aim_deg: f32,
    /// The springs it drives.
    pub springs: SpringMask,
    /// Form once reached.
    pub form: bool,
    /// Where it is.
    pub phase: PosePhase,
    /// The target has been reached (announced once).
    pub reached: bool,
    /// Since when it has been waiting with the springs off (hold, or above the target):
    /// past `hold_timeout_s` it returns to standby.
    pub idle_since: Option<Millis>,
    /// Where the steps last gained: the bend, the selected springs' hottest estimate and
    /// largest austenite fraction (None: no step yet, or re-stepping from a hold).
    pub gained: Option<Gain>,
    /// Steps since that gain.
    pub stalled: u8,
    /// The bend when it last decided to step, degrees (NaN: not yet).
    pub last_step_deg: f32,
}

/// What a pose's steps have reached: the bend and its selected springs' state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gain {
    /// The estimated bend, degrees.
    pub bend_deg: f32,
    /// The hottest selected spring's estimate, K.
    pub spring_k: f32,
    /// The largest selected spring's austenite fraction.
    pub austenite: f32,
}

impl Gain {
    fn of(springs: SpringMask, bend_deg: f32, e: &Estimate) -> Gain {
        let sel = (0..SPRINGS).filter(|&i| springs.contains(i));
        Gain {
            bend_deg,
            spring_k: sel.clone().map(|i| e.springs_k[i]).fold(f32::MIN, f32::max),
            austenite: sel.map(|i| e.austenite[i]).fold(f32::MIN, f32::max),
        }
    }

    /// Whether `now` is a gain over `self`.
    fn beaten_by(&self, now: &Gain) -> bool {
        now.bend_deg >= self.bend_deg + GAIN_DEG
            || now.spring_k >= self.spring_k + GAIN_K
            || now.austenite >= self.austenite + GAIN_AUSTENITE
    }
}

/// The weakest of `springs`' measured power shares ([`Estimate::springs_power_share`]; 1
/// for none).
pub fn power_share(springs: SpringMask, e: &Estimate) -> f32 {
    (0..SPRINGS)
        .filter(|&i| springs.contains(i))
        .map(|i| e.springs_power_share[i])
        .filter(|x| x.is_finite())
        .fold(1.0f32, f32::min)
        .max(0.0)
}

/// How far `springs` bend the soft column at the power their channels measured: each as
/// austenite as its power share lets it become under the duty limit, held at most at
/// `spring_hot_k` beside a wall at `hot_k` ([`attainable_austenite`]), degrees. At the
/// model's power (or any supply above a small share of it) this is
/// [`Posture::reach_deg`]: the supply decides how fast the springs transform, not how far.
pub fn reach_at_power_deg(
    springs: SpringMask,
    s: &Settings,
    e: &Estimate,
    p: &SpringParams,
    phi: f32,
) -> f32 {
    let a: [f32; SPRINGS] = core::array::from_fn(|i| {
        if springs.contains(i) {
            let share = e.springs_power_share[i];
            let share = if share.is_finite() { share } else { 1.0 };
            attainable_austenite(
                p,
                share,
                s.spring_duty_max,
                e.ambient_k,
                s.hot_k,
                s.spring_hot_k,
            )
        } else {
            0.0
        }
    });
    Posture::reach_with_deg(&a, phi)
}

impl Posing {
    /// A pose to `target_deg` with `springs`, from a soak: bent to `aim_deg` (the target, or
    /// with `form` past it by the spring-back) and formed there with `form`.
    pub fn new(target_deg: f32, aim_deg: f32, springs: SpringMask, form: bool) -> Posing {
        Posing {
            target_deg,
            aim_deg,
            springs,
            form,
            phase: PosePhase::Soak { warned: false },
            reached: false,
            idle_since: None,
            gained: None,
            stalled: 0,
            last_step_deg: f32::NAN,
        }
    }

    /// Why the pose, about to step again at `bend_deg`, is short for good (None: step):
    /// every selected spring austenite and the bend no further than at the last step (the
    /// bend estimate lags the springs by a settle or so); the springs' measured power reaching
    /// short of the aim; or [`MAX_STALLED_STEPS`] steps without a gain.
    fn short(&mut self, c: &Ctx, bend_deg: f32) -> Option<ShortBy> {
        let e = c.estimate;
        let full =
            (0..SPRINGS).all(|i| !self.springs.contains(i) || e.austenite[i] >= FULL_AUSTENITE);
        let moving = bend_deg >= self.last_step_deg + GAIN_DEG;
        self.last_step_deg = bend_deg;
        if full && !moving {
            return Some(ShortBy::Austenite);
        }
        let share = power_share(self.springs, e);
        let p = &c.observer.params().springs;
        let reach_deg = reach_at_power_deg(self.springs, &c.s, e, p, c.s.soft_frozen_max);
        if reach_deg < self.aim_deg - c.s.pose_tol_deg {
            return Some(ShortBy::Power { reach_deg, share });
        }
        let now = Gain::of(self.springs, bend_deg, e);
        match self.gained {
            Some(g) if !g.beaten_by(&now) => {
                self.stalled = self.stalled.saturating_add(1);
                if self.stalled >= MAX_STALLED_STEPS {
                    return Some(ShortBy::Stalled {
                        steps: self.stalled,
                        share,
                    });
                }
            }
            _ => {
                self.gained = Some(now);
                self.stalled = 0;
            }
        }
        None
    }

    /// One step of the pose.
    pub(super) fn advance(&mut self, c: &mut Ctx) -> ModeStep {
        let s = c.s;
        let now = c.now;
        let bend = c.bend;
        let error_deg = self.aim_deg - bend.deg;
        let mut next = None;
        let mut idle = false;
        match &mut self.phase {
            PosePhase::Soak { warned } => match c.softened(warned) {
                Soak::Go => self.phase = PosePhase::Settle { left_ms: 0 },
                Soak::GiveUp => next = Some(Next::GiveUp("soak")),
                Soak::Wait => {}
            },
            PosePhase::Step { left_ms } => {
                *left_ms = left_ms.saturating_sub(c.elapsed_ms);
                if *left_ms == 0 {
                    self.phase = PosePhase::Settle {
                        left_ms: ms(SETTLE_S),
                    };
                }
            }
            PosePhase::Settle { left_ms } => {
                *left_ms = left_ms.saturating_sub(c.elapsed_ms);
                if *left_ms == 0 {
                    if error_deg.abs() <= s.pose_tol_deg {
                        self.phase = PosePhase::Hold;
                        if !self.reached {
                            self.reached = true;
                            c.announce(Notice::PoseReached {
                                deg: bend.deg,
                                sd_deg: bend.sd_deg,
                                rest_deg: self.form.then_some(self.target_deg),
                            });
                            if self.form {
                                self.phase = PosePhase::Form {
                                    since: now,
                                    on: false,
                                    left_ms: ms(SETTLE_S),
                                    budget_ms: ms(FORM_STEP_BUDGET_S),
                                };
                            }
                        }
                    } else if error_deg > 0.0 {
                        if let Some(why) = self.short(c, bend.deg) {
                            c.announce(Notice::PoseOutOfReach { deg: bend.deg, why });
                            c.events
                                .push(now, EventKind::PoseOutOfReach { deg: bend.deg, why });
                            next = Some(Next::Enter(Mode::Standby));
                        } else {
                            // A step gives the energy the model's power gives in its length:
                            // a weak supply's steps are longer.
                            let share = power_share(self.springs, c.estimate).max(MIN_STEP_SHARE);
                            let step_s = clamp(
                                POSE_S_PER_DEG * error_deg / share,
                                MIN_STEP_S / share,
                                s.step_s,
                            );
                            self.phase = PosePhase::Step {
                                left_ms: ms(step_s),
                            };
                        }
                    } else {
                        // Above the target: the soft wall's memory brings it back (springs
                        // off); judged again after another settle.
                        idle = true;
                        *left_ms = ms(SETTLE_S);
                    }
                }
            }
            PosePhase::Hold => {
                idle = true;
                if error_deg > s.pose_tol_deg {
                    self.phase = PosePhase::Settle { left_ms: 0 };
                    self.gained = None;
                }
            }
            PosePhase::Form {
                since,
                on,
                left_ms,
                budget_ms,
            } => {
                *left_ms = left_ms.saturating_sub(c.elapsed_ms);
                match c.cooled(*since) {
                    Soak::Go => next = Some(Next::Enter(Mode::Standby)),
                    Soak::GiveUp => next = Some(Next::GiveUp("form")),
                    Soak::Wait => {}
                }
                if *left_ms == 0 {
                    let sag_deg = error_deg - 0.5 * s.pose_tol_deg;
                    let step_ms =
                        ms(clamp(POSE_S_PER_DEG * sag_deg, MIN_STEP_S, s.step_s)).min(*budget_ms);
                    if !*on
                        && sag_deg > 0.0
                        && c.estimate.frozen < FORM_STEP_FROZEN_MAX
                        && step_ms > 0
                    {
                        *on = true;
                        *left_ms = step_ms;
                        *budget_ms -= step_ms;
                    } else {
                        *on = false;
                        *left_ms = ms(SETTLE_S);
                    }
                }
            }
        }
        if !idle {
            self.idle_since = None;
        } else if now.seconds_since(*self.idle_since.get_or_insert(now)).s() > s.hold_timeout_s {
            next = Some(Next::GiveUp("hold"));
        }
        // A spring whose on-time the step would take past the limit, or near its duty limit,
        // sits the step out.
        let stepping = |left_ms: u32| {
            let room = c.safety.duty_room(&s);
            let band = c.band(self.springs, s.spring_hot_k);
            let bits = (0..SPRINGS)
                .filter(|&i| {
                    band.contains(i)
                        && room.contains(i)
                        && c.safety.spring_may_run(i, left_ms as f32 * 1e-3, &s)
                })
                .fold(0u8, |b, i| b | 1 << i);
            SpringMask::from_bits(bits)
        };
        let (drive, springs) = match self.phase {
            PosePhase::Step { left_ms } => (Drive::Hold(s.hot_k), stepping(left_ms)),
            PosePhase::Form {
                on: true, left_ms, ..
            } => (Drive::Cool, stepping(left_ms)),
            PosePhase::Form { on: false, .. } => (Drive::Cool, SpringMask::NONE),
            PosePhase::Soak { .. } | PosePhase::Settle { .. } | PosePhase::Hold => {
                (Drive::Hold(s.hot_k), SpringMask::NONE)
            }
        };
        ModeStep {
            drive,
            springs,
            next,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::Observer;
    use crate::posture::Bend;
    use crate::supervisor::events::EventLog;
    use crate::supervisor::safety::Safety;

    /// A pose stepped with a fixed estimate (the springs at `spring_k`, half austenite, at
    /// `share` of the model's power) and a fixed bend: what its steps last, and how it ends.
    fn run(share: f32, spring_k: f32) -> (Vec<u32>, Option<Notice>, EventLog, Posing) {
        let s = Settings::DEFAULT;
        let observer = Observer::new(&s.observer_params(), 298.15);
        let mut estimate = observer.estimate();
        estimate.springs_k = [spring_k; SPRINGS];
        estimate.austenite = [0.5; SPRINGS];
        estimate.springs_power_share = [share; SPRINGS];
        estimate.frozen = 0.0;
        let safety = Safety::new();
        let mut events = EventLog::new();
        let mut notice = None;
        let ab = SpringMask::parse("AB").unwrap();
        let mut pose = Posing::new(40.0, 40.0, ab, false);
        pose.phase = PosePhase::Settle { left_ms: 0 };
        let mut steps = Vec::new();
        for k in 0..2_000u64 {
            let mut c = Ctx {
                now: Millis(k * 250),
                elapsed_ms: 250,
                s,
                tc_k: s.hot_k,
                hotter_k: Some(s.hot_k),
                mode_since: Millis(0),
                fresh: None,
                last_heater: crate::outputs::Duty::OFF,
                last_springs: SpringMask::NONE,
                estimate: &estimate,
                bend: Bend {
                    deg: 30.0,
                    sd_deg: 1.0,
                },
                observer: &observer,
                safety: &safety,
                events: &mut events,
                notice: &mut notice,
            };
            let was_step = matches!(pose.phase, PosePhase::Step { .. });
            let step = pose.advance(&mut c);
            if let (false, PosePhase::Step { left_ms }) = (was_step, pose.phase) {
                steps.push(left_ms);
            }
            if step.next.is_some() {
                break;
            }
        }
        (steps, notice, events, pose)
    }

    /// A weak supply's steps are longer by its share (the model's energy a step); steps that
    /// gain nothing end the pose short, with the reason in the notice and the log.
    #[test]
    fn steps_stretch_with_a_weak_supply_and_a_stall_ends_the_pose() {
        let (full, notice, events, pose) = run(1.0, 350.0);
        let (half, ..) = run(0.5, 350.0);
        // 10° missing: 2.5 s at the model's power, 5 s at half of it.
        assert_eq!(full[0], 2_500);
        assert_eq!(half[0], 5_000);
        assert_eq!(full.len(), MAX_STALLED_STEPS as usize, "{full:?}");
        assert_eq!(pose.stalled, MAX_STALLED_STEPS);
        let Some(Notice::PoseOutOfReach {
            deg,
            why: ShortBy::Stalled { steps, share },
        }) = notice
        else {
            panic!("{notice:?}")
        };
        assert_eq!((deg, steps, share), (30.0, MAX_STALLED_STEPS, 1.0));
        let said = std::format!("{}", notice.unwrap());
        assert_eq!(
            said,
            "pose out of reach at 30.0: 10 steps gained nothing with the springs at 100 % of their power"
        );
        assert!(
            events
                .iter()
                .any(|e| matches!(e.kind, EventKind::PoseOutOfReach { .. }))
        );
    }

    /// Springs whose supply gives a few percent of the model's power cannot become austenite
    /// under the duty limit: the pose ends at its first step with what that power reaches.
    #[test]
    fn a_supply_too_weak_to_transform_ends_the_pose_at_once() {
        let (steps, notice, ..) = run(0.03, 300.0);
        assert!(steps.is_empty(), "{steps:?}");
        let Some(Notice::PoseOutOfReach {
            why: ShortBy::Power { reach_deg, share },
            ..
        }) = notice
        else {
            panic!("{notice:?}")
        };
        assert!(
            reach_deg < 10.0 && (share - 0.03).abs() < 1e-6,
            "{notice:?}"
        );
    }
}
