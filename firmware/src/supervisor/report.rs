//! The supervisor's words: reply lines (`ok …` / `err <code>: <message>`) and telemetry lines
//! (`# …`). This module owns their formats; docs/console.md documents them.
//!
//! A reply is one line without its end (the board adds CR LF). It never holds a line break,
//! and a reply that would not fit [`REPLY_CAP`] is cut and ends in ` ...`.

use core::fmt::{self, Write};

use super::events::{EventKind, EventLog};
use super::safety::Fault;
use super::{Mode, Supervisor};
use crate::command::COMMANDS;
use crate::decimal::{Fixed, Shortest, Thousandths};
use crate::observer::Estimate;
use crate::outputs::{SPRINGS, SpringMask};
use crate::settings::{PARAMS, Param, Settings};
use crate::units::{Kelvin, Millis};

/// Longest reply line, bytes.
pub const REPLY_CAP: usize = 2048;

/// One reply line.
#[derive(Clone, PartialEq, Eq)]
pub struct Reply {
    buf: heapless::String<REPLY_CAP>,
    cut: bool,
    listing: bool,
}

impl fmt::Debug for Reply {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Write for Reply {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        if self.cut {
            return Ok(());
        }
        for c in s.chars() {
            // Never a line break inside a reply.
            let c = if c == '\r' || c == '\n' { ' ' } else { c };
            if self.buf.len() + c.len_utf8() > REPLY_CAP - 4 {
                self.cut = true;
                let _ = self.buf.push_str(" ...");
                return Ok(());
            }
            let _ = self.buf.push(c);
        }
        Ok(())
    }
}

impl Reply {
    fn new() -> Reply {
        Reply {
            buf: heapless::String::new(),
            cut: false,
            listing: false,
        }
    }

    /// Whether `settings`' listing comes before this line: one `#` line a parameter
    /// ([`write_setting`]), written by the caller from the supervisor's settings of the same
    /// period, then this reply. Every line stays a line of its own (the protocol's `#` lines).
    pub fn lists_settings(&self) -> bool {
        self.listing
    }

    /// Return the line (without its end).
    pub fn as_str(&self) -> &str {
        self.buf.as_str()
    }

    /// Return whether it is an `ok` reply.
    pub fn is_ok(&self) -> bool {
        self.buf.starts_with("ok")
    }

    fn with(f: impl FnOnce(&mut Reply) -> fmt::Result) -> Reply {
        let mut r = Reply::new();
        // Writing into a Reply cannot fail (it cuts instead).
        let _ = f(&mut r);
        r
    }

    /// `ok <text>`.
    pub fn ok(text: &str) -> Reply {
        Reply::with(|r| write!(r, "ok {text}"))
    }

    /// `err <code>: <message>`.
    pub fn err(code: &str, message: &str) -> Reply {
        Reply::with(|r| write!(r, "err {code}: {message}"))
    }

    /// A `set`, `load` or `defaults` refused: it would relax the limit `name` while a fault is
    /// latched.
    pub(super) fn relaxed(name: &str) -> Reply {
        Reply::with(|r| {
            write!(
                r,
                "err bad-state: a fault is latched: {name} would be relaxed; nothing changed \
                 (`reset` first)"
            )
        })
    }

    /// `reset` refused: spring `spring`'s sensing reads garbage (an ADC that stopped), so the
    /// probe cannot check the channels.
    pub(super) fn unreadable(spring: char) -> Reply {
        Reply::with(|r| {
            write!(
                r,
                "err cause-present: spring {spring}'s sensing reads beyond 12 bits: \
                 the channels cannot be checked"
            )
        })
    }

    /// `reset` refused: spring `spring` conducts `amps` with its gate off.
    pub(super) fn conducting(spring: char, amps: f32) -> Reply {
        Reply::with(|r| {
            write!(
                r,
                "err cause-present: spring {spring} conducts {} A with its gate off",
                Fixed::new(amps, 1)
            )
        })
    }

    /// `mode pose`'s reply: the target, the springs and what they can reach (or why not): a
    /// target beyond `limit_deg` (the reach, or with `form` the reach the formed column rests
    /// at plus the tolerance) is refused.
    pub(super) fn pose(
        target_deg: f32,
        springs: SpringMask,
        reach_deg: f32,
        limit_deg: f32,
        form: bool,
    ) -> Reply {
        Reply::with(|r| {
            if target_deg > limit_deg {
                write!(
                    r,
                    "err out-of-reach: springs {springs} reach {}",
                    Fixed::new(reach_deg, 1)
                )
            } else {
                write!(
                    r,
                    "ok mode pose {} springs={springs} reach_deg={}{}",
                    Fixed::new(target_deg, 1),
                    Fixed::new(reach_deg, 1),
                    if form { " form" } else { "" }
                )
            }
        })
    }

    /// The reply to a line refused by the parser.
    pub fn parse_error(e: crate::command::ParseError) -> Reply {
        Reply::with(|r| write!(r, "err {}: {e}", e.code()))
    }

    /// `help`: every command with its arguments; `help COMMAND` (`topic`, an index into
    /// [`COMMANDS`]): that command's arguments and what it does, and for a command that takes
    /// a NAME (`get`, `set`) every parameter's name.
    pub(super) fn help(topic: Option<u8>) -> Reply {
        if let Some(c) = topic.and_then(|i| COMMANDS.get(i as usize)) {
            return Reply::with(|r| {
                if c.args.is_empty() {
                    write!(r, "ok {}: {}", c.name, c.help)?;
                } else {
                    write!(r, "ok {} {}: {}", c.name, c.args, c.help)?;
                }
                if matches!(c.name, "get" | "set") {
                    r.write_str("; NAME:")?;
                    for p in PARAMS {
                        write!(r, " {}", p.name)?;
                    }
                }
                Ok(())
            });
        }
        Reply::with(|r| {
            r.write_str("ok commands:")?;
            for (i, c) in COMMANDS.iter().enumerate() {
                let sep = if i == 0 { " " } else { "; " };
                if c.args.is_empty() {
                    write!(r, "{sep}{}", c.name)?;
                } else {
                    write!(r, "{sep}{} {}", c.name, c.args)?;
                }
            }
            Ok(())
        })
    }

    /// `version`: the crate's version, and on the board the commit it was built from
    /// ([`crate::BUILD`]).
    pub(super) fn version() -> Reply {
        Reply::with(|r| {
            write!(r, "ok thermorph {}", crate::VERSION)?;
            match crate::BUILD {
                Some(build) => write!(r, " ({build})"),
                None => Ok(()),
            }
        })
    }

    /// `status`: every field (docs/console.md's table); `short`: the same fields' subset a
    /// person watches, in the same order and format (mode, phase, target, Tc, outputs, bend,
    /// fault).
    pub(super) fn status(s: &Supervisor, now: Millis, short: bool) -> Reply {
        Reply::with(|r| {
            write!(r, "ok mode={} phase={}", s.mode.name(), s.mode.phase_name())?;
            write_k(r, "target_k", s.target_k())?;
            write_k(r, "tc_k", s.tc_k)?;
            if !short {
                write_measurement(r, s, now)?;
            }
            write!(
                r,
                " heater_pct={} fan_pct={} springs={}",
                Fixed::new(s.outputs.heater.pct(), 1),
                Fixed::new(s.outputs.fan.pct(), 1),
                s.outputs.springs
            )?;
            if !short {
                write!(r, " select={}", s.springs)?;
                write_channels(r, s)?;
            }
            write_bend(r, &s.posture.bend())?;
            if !short {
                write_estimate(r, &s.observer.estimate())?;
            }
            match s.fault {
                Some(f) => write!(r, " fault={} reason=\"{}\"", f.code(), f.reason()),
                None => r.write_str(" fault=none"),
            }
        })
    }

    pub(super) fn log(events: &EventLog) -> Reply {
        Reply::with(|r| {
            write!(r, "ok events={}", events.total())?;
            for e in events.iter() {
                write!(r, " | {} ", Fixed::new(e.at.ms() as f32 * 1e-3, 2))?;
                write_event(r, &e.kind)?;
            }
            Ok(())
        })
    }

    /// `settings`' reply, after its listing: how many parameters, and how many are not their
    /// defaults (marked `*`).
    pub(super) fn settings(s: &Settings) -> Reply {
        let changed = PARAMS
            .iter()
            .filter(|p| (p.get)(s) != (p.get)(&DEFAULTS))
            .count();
        let mut r = Reply::with(|r| {
            write!(
                r,
                "ok {} parameters, {changed} not the default (*)",
                PARAMS.len()
            )
        });
        r.listing = true;
        r
    }

    pub(super) fn get_all(s: &Settings) -> Reply {
        Reply::with(|r| {
            r.write_str("ok")?;
            for p in PARAMS {
                write!(r, " {}=", p.name)?;
                write_param(r, p, (p.get)(s), true)?;
            }
            Ok(())
        })
    }

    pub(super) fn get(s: &Settings, i: usize) -> Reply {
        match PARAMS.get(i) {
            Some(p) => Reply::with(|r| {
                write!(r, "ok {}=", p.name)?;
                write_param(r, p, (p.get)(s), true)?;
                if !p.unit.is_empty() {
                    write!(r, " {}", p.unit)?;
                }
                Ok(())
            }),
            None => Reply::err("unknown-name", "no such parameter"),
        }
    }

    pub(super) fn out_of_range(p: &Param, min: f32, max: f32) -> Reply {
        Reply::with(|r| {
            write!(r, "err out-of-range: {} must be in [", p.name)?;
            write_param(r, p, min, false)?;
            r.write_str(", ")?;
            write_param(r, p, max, false)?;
            write!(r, "] {}", p.unit)
        })
    }

    pub(super) fn stream_on(hz: f32) -> Reply {
        // The rate as typed (its shortest text).
        Reply::with(|r| write!(r, "ok stream on {} Hz", Shortest::new(hz)))
    }

    pub(super) fn fault_latched(f: Option<Fault>) -> Reply {
        Reply::with(|r| match f {
            Some(f) => write!(
                r,
                "err fault-latched: {} ({}); `reset` first",
                f.code(),
                f.reason()
            ),
            None => r.write_str("err fault-latched: `reset` first"),
        })
    }

    pub(super) fn cause_present(f: Fault) -> Reply {
        Reply::with(|r| {
            write!(
                r,
                "err cause-present: {} ({}) is not gone",
                f.code(),
                f.reason()
            )
        })
    }

    pub(super) fn mode(m: &Mode, springs: SpringMask) -> Reply {
        Reply::with(|r| {
            if m.id().takes_springs() {
                write!(r, "ok mode {} springs={springs}", m.name())
            } else {
                write!(r, "ok mode {}", m.name())
            }
        })
    }
}

/// A parameter's value in its console unit: a count as a whole number, any other value in the
/// fewest decimals that read back as it ([`Shortest`]: `hot_k=358 K`, `ki=0.0004 1/(K*s)`; a
/// `stored` percentage, kept as a fraction, in the fewest whose fraction gives it: `60 %`), so
/// that `set NAME <what get showed>` changes nothing. A range's bound (not `stored`) is the
/// table's number.
#[inline(never)]
fn write_param(r: &mut dyn Write, p: &Param, v: f32, stored: bool) -> fmt::Result {
    if !v.is_finite() {
        r.write_str("-")
    } else if p.integer {
        write!(r, "{}", libm::roundf(v) as i32)
    } else if p.percent && stored {
        write!(r, "{}", Shortest::percent(v))
    } else {
        write!(r, "{}", Shortest::new(v))
    }
}

/// One line of `settings`' listing, with its `#` and CR LF: parameter `i`'s name, value, unit,
/// default and range, `*` before the name where the value is not the default:
///
/// ```text
/// # * hot_k                       360         K        default 358, 338 to 368
/// #   kp                          0.139       1/K      default 0.139, 0 to 10
/// ```
///
/// Columns: `# `, the mark and a space; the name (28 wide: the longest and a space); the value
/// as `get` writes it (12 wide); the unit (9 wide); then `default D, MIN to MAX`. Nothing for an
/// `i` past [`PARAMS`].
#[inline(never)]
pub fn write_setting(out: &mut dyn Write, s: &Settings, i: usize) -> fmt::Result {
    let Some(p) = PARAMS.get(i) else {
        return Ok(());
    };
    let (v, d) = ((p.get)(s), (p.get)(&DEFAULTS));
    // Through the trait object, not the board's one writer inlined here (flash: its pushes
    // of padding become a memset routine).
    let out = core::hint::black_box(out);
    // Columns padded by hand: `{:<27}` pads with `write_char`, one more routine in flash.
    let pad = |out: &mut dyn Write, wrote: usize, width: usize| {
        out.write_str(
            SPACES
                .get(..width.saturating_sub(wrote))
                .unwrap_or_default(),
        )
    };
    out.write_str(if v == d { "#   " } else { "# * " })?;
    out.write_str(p.name)?;
    pad(out, p.name.len(), 28)?;
    let mut width = Width(0);
    write_param(&mut width, p, v, true)?;
    write_param(out, p, v, true)?;
    pad(out, width.0, 12)?;
    out.write_str(p.unit)?;
    pad(out, p.unit.len(), 9)?;
    out.write_str("default ")?;
    write_param(out, p, d, true)?;
    out.write_str(", ")?;
    write_param(out, p, p.min, false)?;
    out.write_str(" to ")?;
    write_param(out, p, p.max, false)?;
    out.write_str("\r\n")
}

/// How many lines `settings`' listing has ([`write_setting`]'s `i` below it): one a parameter.
pub const SETTING_LINES: usize = PARAMS.len();

/// The defaults `settings` compares with: one copy in flash, not one built on the stack for
/// each use of the constant.
static DEFAULTS: Settings = Settings::DEFAULT;

/// `settings`' columns' padding.
const SPACES: &str = "                            ";

/// Counts the bytes written to it.
struct Width(usize);

impl Write for Width {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.0 += s.len();
        Ok(())
    }
}

/// `status`' fields of the last frame: the regions, the measurement's quality, number, age and
/// filled pixels, and the lattice's exposed fraction with the design MTTS fits with (the
/// configured one, or what the frames adopted in its place).
fn write_measurement(r: &mut impl Write, s: &Supervisor, now: Millis) -> fmt::Result {
    match s.last {
        Some(m) => {
            for (i, t) in m.regions.iter().enumerate() {
                match t {
                    Some(t) => write!(r, " t{}_k={}", i + 1, Fixed::new(t.k(), 3))?,
                    None => write!(r, " t{}_k=-", i + 1)?,
                }
            }
            write!(
                r,
                " quality={} frame={} age_s={} filled={}",
                m.quality.name(),
                m.seq,
                Fixed::new(now.seconds_since(m.at).s(), 2),
                m.filled_pixels
            )?;
        }
        None => r.write_str(" t1_k=- t2_k=- t3_k=- t4_k=- t5_k=- quality=- frame=- age_s=-")?,
    }
    match s.last.and_then(|m| m.exposure) {
        Some(e) => write!(
            r,
            " exposed_pct={} design_pct={}",
            Fixed::new(e.fitted_pct, 1),
            Fixed::new(e.design_pct, 1)
        ),
        None => r.write_str(" exposed_pct=- design_pct=-"),
    }
}

/// The bend estimate's fields: ` bend_deg=… bend_sd_deg=…`.
/// The spring power enable and, on a board that senses its springs, each channel's current
/// and supply (`-` where unknown).
fn write_channels(r: &mut impl Write, s: &Supervisor) -> fmt::Result {
    let on = if s.outputs.spring_power { "on" } else { "off" };
    write!(r, " spring_power={on}")?;
    if !s.channels.present() {
        return Ok(());
    }
    let st = s.channels.state();
    for (name, values) in [
        ("spring_a", st.map(|c| c.current_a)),
        ("supply_v", st.map(|c| c.supply_v)),
    ] {
        write!(r, " {name}=")?;
        for (i, v) in values.into_iter().enumerate() {
            let sep = if i == 0 { "" } else { "," };
            if v.is_finite() {
                write!(r, "{sep}{}", Fixed::new(v, 2))?;
            } else {
                write!(r, "{sep}-")?;
            }
        }
    }
    Ok(())
}

fn write_bend(r: &mut impl Write, b: &crate::posture::Bend) -> fmt::Result {
    write!(
        r,
        " bend_deg={} bend_sd_deg={}",
        Fixed::new(b.deg, 2),
        Fixed::new(b.sd_deg, 2)
    )
}

fn write_k(r: &mut impl Write, name: &str, v: f32) -> fmt::Result {
    if v.is_finite() {
        write!(r, " {name}={}", Fixed::new(v, 2))
    } else {
        write!(r, " {name}=-")
    }
}

fn write_event(r: &mut impl Write, e: &EventKind) -> fmt::Result {
    match e {
        EventKind::Mode { from, to } => write!(r, "mode {from} -> {to}"),
        EventKind::Fault(f) => write!(r, "fault {} ({})", f.code(), f.reason()),
        EventKind::Cleared(f) => write!(r, "cleared {}", f.code()),
        EventKind::Tuned { ku_per_k, tu_s } => {
            let (ku, tu) = (Fixed::new(*ku_per_k, 4), Fixed::new(*tu_s, 1));
            write!(r, "autotune done ku={ku}/K tu={tu} s")
        }
        EventKind::TuneAborted(why) => write!(r, "autotune aborted ({why})"),
        EventKind::SteppingDone => r.write_str("stepping done"),
        EventKind::RecoveryCooling => r.write_str("recovery: straight, cooling to lock it"),
        EventKind::SpringsResting => r.write_str("springs warm: stepping waits for them to rest"),
        EventKind::Warning(w) => write!(r, "warning: {w}"),
        EventKind::PoseOutOfReach { deg, why } => write!(
            r,
            "pose out of reach at {} deg ({why}), standby",
            Fixed::new(*deg, 1)
        ),
        EventKind::TimedOut { what, tc_k } => {
            write!(
                r,
                "{what} timed out at tc={} K, standby",
                Fixed::new(*tc_k, 2)
            )
        }
    }
}

/// The observer's fields (`status` and telemetry), in order: the wall's frozen fraction and
/// inner layer, the ambient, each spring's temperature and austenite fraction, each with its
/// standard deviation.
pub const ESTIMATE_FIELDS: [&str; 18] = [
    "frozen_pct",
    "frozen_std_pct",
    "inner_k",
    "inner_std_k",
    "ambient_est_k",
    "ambient_std_k",
    "spring_a_k",
    "spring_a_std_k",
    "spring_b_k",
    "spring_b_std_k",
    "spring_c_k",
    "spring_c_std_k",
    "aus_a_pct",
    "aus_a_std_pct",
    "aus_b_pct",
    "aus_b_std_pct",
    "aus_c_pct",
    "aus_c_std_pct",
];

/// Write the observer's fields ([`ESTIMATE_FIELDS`]), each as ` name=value`.
fn write_estimate(r: &mut impl Write, e: &Estimate) -> fmt::Result {
    let pct = |x: f32| x * 100.0;
    let mut values = [0.0f32; ESTIMATE_FIELDS.len()];
    values[..6].copy_from_slice(&[
        pct(e.frozen),
        pct(e.frozen_std),
        e.layers_k[0],
        e.layers_std_k[0],
        e.ambient_k,
        e.ambient_std_k,
    ]);
    for i in 0..SPRINGS {
        values[6 + 2 * i] = e.springs_k[i];
        values[7 + 2 * i] = e.springs_std_k[i];
        values[12 + 2 * i] = pct(e.austenite[i]);
        values[13 + 2 * i] = pct(e.austenite_std[i]);
    }
    for (name, v) in ESTIMATE_FIELDS.iter().zip(values) {
        write_k(r, name, v)?;
    }
    Ok(())
}

/// The loop's telemetry fields, the line's first ones (with the bend estimate's last).
const LOOP_FIELDS: [&str; 14] = [
    "t_s",
    "mode",
    "phase",
    "t1_k",
    "t2_k",
    "tc_k",
    "target_k",
    "heater_pct",
    "fan_pct",
    "springs",
    "quality",
    "fault",
    "bend_deg",
    "bend_sd_deg",
];

/// The telemetry line's fields, in order (docs/console.md's table is checked against this):
/// the loop's, then the observer's ([`ESTIMATE_FIELDS`]).
pub const TELEMETRY_FIELDS: [&str; LOOP_FIELDS.len() + ESTIMATE_FIELDS.len()] = {
    let mut out = [""; LOOP_FIELDS.len() + ESTIMATE_FIELDS.len()];
    let mut i = 0;
    while i < LOOP_FIELDS.len() {
        out[i] = LOOP_FIELDS[i];
        i += 1;
    }
    let mut j = 0;
    while j < ESTIMATE_FIELDS.len() {
        out[LOOP_FIELDS.len() + j] = ESTIMATE_FIELDS[j];
        j += 1;
    }
    out
};

/// Write one telemetry line: `# t_s=… mode=… phase=… t1_k=… t2_k=… tc_k=… target_k=…
/// heater_pct=… fan_pct=… springs=… quality=… fault=…`, the observer's fields, and CR LF.
pub fn telemetry(s: &Supervisor, now: Millis, out: &mut impl Write) -> fmt::Result {
    write!(
        out,
        "# t_s={} mode={} phase={}",
        Thousandths(now.ms()),
        s.mode.name(),
        s.mode.phase_name()
    )?;
    let (t1, t2) = s.last.map_or((f32::NAN, f32::NAN), |m| {
        let k = |t: Option<Kelvin>| t.map_or(f32::NAN, Kelvin::k);
        (k(m.t1()), k(m.t2()))
    });
    write_k(out, "t1_k", t1)?;
    write_k(out, "t2_k", t2)?;
    write_k(out, "tc_k", s.tc_k)?;
    write_k(out, "target_k", s.target_k())?;
    write!(
        out,
        " heater_pct={} fan_pct={} springs={} quality={} fault={}",
        Fixed::new(s.outputs.heater.pct(), 1),
        Fixed::new(s.outputs.fan.pct(), 1),
        s.outputs.springs,
        s.last.map_or("-", |m| m.quality.name()),
        s.fault.map_or("none", |f| f.code())
    )?;
    write_bend(out, &s.posture.bend())?;
    write_estimate(out, &s.observer.estimate())?;
    out.write_str("\r\n")
}
