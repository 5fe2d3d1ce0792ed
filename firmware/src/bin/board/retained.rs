//! The springs' memory kept in RAM across a reset of the chip.
//!
//! Nothing measures a spring's temperature (the board measures its current and supply only
//! while it runs), so the supervisor models their heat, duty and on-time ([`SpringMemory`]). The control loop writes that memory ([`keep`]) after every control
//! step into a RAM block that cortex-m-rt neither zeroes nor initializes (the `.uninit`
//! section, a `MaybeUninit` static). At boot ([`take`]) the reset flags in RCC_CSR say why the
//! chip started (a [`ResetCause`], see `reset.rs`; `Supervisor::boot` comes up `stopped` and
//! says why after any reset but a power-up) and decide what the RAM holds:
//!
//! - PORRSTF or BORRSTF (a power-up or a brown-out): RAM is not to be trusted and the springs
//!   may have had any history: [`Boot::PowerUp`], and the supervisor gets no memory (springs
//!   assumed hot).
//! - any other reset (the watchdog, a fault handler's `sys_reset`, the reset button, a
//!   debugger's reset): RAM kept its contents, so the words written last are read back;
//!   [`SpringMemory::from_words`] checks their magic word, count and CRC, and the memory
//!   found is handed to `Supervisor::boot` ([`Boot::Kept`]); words that do not check
//!   (never written, or written by an image with another layout) give [`Boot::Unchecked`]
//!   and no memory.
//!
//! The flags are then cleared (RMVF), so the next boot sees only the next reset's.
//!
//! The memory kept is at most one control period old; the springs cooled during the reset and
//! the boot, which the restored memory does not count (it errs hot). It does not count either
//! what a stalled loop left on before the watchdog reset (at most the watchdog's 500 ms with
//! the springs as last applied; a fault handler turns them off at once).

use core::mem::MaybeUninit;

use embassy_stm32::pac::RCC;
use thermorph::supervisor::memory::MEMORY_WORDS;
use thermorph::supervisor::{ResetCause, SpringMemory};

#[path = "reset.rs"]
mod reset;

/// The words of the last [`SpringMemory`], kept across a reset (never zeroed at start).
#[unsafe(link_section = ".uninit.thermorph_spring_memory")]
static mut WORDS: MaybeUninit<[u32; MEMORY_WORDS]> = MaybeUninit::uninit();

/// What the boot found in RAM.
pub enum Boot {
    /// A power-up or brown-out: nothing kept.
    PowerUp,
    /// A reset that kept RAM, with the springs' memory it found.
    Kept(SpringMemory),
    /// A reset that kept RAM, but no memory that checks.
    Unchecked,
}

impl Boot {
    /// Return the springs' memory found, if any.
    pub fn memory(&self) -> Option<SpringMemory> {
        match self {
            Boot::Kept(m) => Some(*m),
            Boot::PowerUp | Boot::Unchecked => None,
        }
    }
}

/// Read why the chip started and the memory kept, then clear the reset flags. Call it once,
/// before the first [`keep`].
pub fn take() -> (ResetCause, Boot) {
    let csr = RCC.csr().read();
    RCC.csr().modify(|w| w.set_rmvf(true));
    let flags = reset::Flags {
        power_on: csr.porrstf(),
        brown_out: csr.borrstf(),
        independent_watchdog: csr.wdgrstf(),
        window_watchdog: csr.wwdgrstf(),
        software: csr.sftrstf(),
        pin: csr.padrstf(),
        low_power: csr.lpwrrstf(),
    };
    let cause = flags.cause();
    if !flags.ram_kept() {
        return (cause, Boot::PowerUp);
    }
    let mut words = [0u32; MEMORY_WORDS];
    let base = (&raw const WORDS).cast::<u32>();
    for (i, w) in words.iter_mut().enumerate() {
        // SAFETY: within the static; volatile, as RAM the program never wrote since this
        // start (any bit pattern is a valid u32), and only the control task touches it.
        *w = unsafe { base.add(i).read_volatile() };
    }
    let boot = match SpringMemory::from_words(&words) {
        Some(m) => Boot::Kept(m),
        None => Boot::Unchecked,
    };
    (cause, boot)
}

/// Keep `memory` for the next reset.
pub fn keep(memory: &SpringMemory) {
    let base = (&raw mut WORDS).cast::<u32>();
    for (i, &w) in memory.to_words().iter().enumerate() {
        // SAFETY: within the static; only the control task touches it.
        unsafe { base.add(i).write_volatile(w) };
    }
}
