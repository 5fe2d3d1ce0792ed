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

use super::events::Notice;
use super::mode::{Ctx, Drive, Mode, ModeStep, Next, Soak, ms};
use crate::fmath::clamp;
use crate::outputs::{SPRINGS, SpringMask};
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
        }
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
                        let full = (0..SPRINGS).all(|i| {
                            !self.springs.contains(i) || c.estimate.austenite[i] >= FULL_AUSTENITE
                        });
                        if full {
                            c.announce(Notice::PoseOutOfReach { deg: bend.deg });
                            next = Some(Next::Enter(Mode::Standby));
                        } else {
                            let step_s = clamp(POSE_S_PER_DEG * error_deg, MIN_STEP_S, s.step_s);
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
