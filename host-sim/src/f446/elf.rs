//! The board's ELF as the emulated STM32F446 takes it: the bytes to place in flash (each
//! loadable segment at its load address, `.data`'s initial values included), the code to find
//! `wfe` and `sev` in, and the symbols the harness reads (the RTT control block). An ELF the
//! chip cannot run is refused with one sentence saying why.

use std::path::Path;

use object::elf::{EM_ARM, PT_LOAD};
use object::read::elf::{ElfFile32, FileHeader, ProgramHeader};
use object::{Endianness, Object, ObjectSection, ObjectSymbol, SectionKind};

use super::{FLASH_BASE, FLASH_BYTES, SRAM_BASE, SRAM_BYTES};

/// What the chip takes from an ELF.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Image {
    /// The bytes to place in flash: `(address, bytes)`, each inside the flash.
    pub flash: Vec<(u32, Vec<u8>)>,
    /// The executable sections: `(address, bytes)`.
    pub code: Vec<(u32, Vec<u8>)>,
    /// The RTT control block's address (`_SEGGER_RTT`), if the ELF has one.
    pub rtt: Option<u32>,
    /// The springs' memory kept across a reset (the board's `retained::WORDS`), if the ELF has
    /// it.
    pub spring_memory: Option<u32>,
    /// The initial stack pointer and reset handler (the vector table's first two words).
    pub vectors: (u32, u32),
}

/// Why an ELF cannot run on the emulated chip.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum ElfError {
    /// It cannot be read.
    #[error("{path}: cannot read: {why}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        why: String,
    },
    /// Not an ELF, or not one this reads.
    #[error("{path}: not an ELF file ({why})")]
    NotElf {
        /// The file.
        path: String,
        /// What the parser said.
        why: String,
    },
    /// An ELF for another machine or word size.
    #[error(
        "{path}: an ELF for {machine}, not the STM32F446's Cortex-M4 (32-bit little-endian ARM)"
    )]
    OtherMachine {
        /// The file.
        path: String,
        /// Its machine, as the header names it.
        machine: String,
    },
    /// Its flash image does not fit the chip.
    #[error(
        "{path}: {what} at {addr:#010x} ({bytes} bytes) is outside the STM32F446's flash \
         (0x08000000, 512 KiB): built for another chip or memory layout?"
    )]
    OutsideFlash {
        /// The file.
        path: String,
        /// What lies there.
        what: String,
        /// Its address.
        addr: u32,
        /// Its size.
        bytes: usize,
    },
    /// Its vector table does not start the chip: a stack pointer outside SRAM or a reset
    /// handler outside flash (or not Thumb).
    #[error(
        "{path}: its vector table (SP {sp:#010x}, reset {reset:#010x}) does not start an \
         STM32F446: the stack must be in SRAM (0x20000000, 128 KiB) and the reset handler \
         Thumb code in flash"
    )]
    Vectors {
        /// The file.
        path: String,
        /// The initial stack pointer.
        sp: u32,
        /// The reset vector.
        reset: u32,
    },
}

/// Read the ELF at `path` for the emulated chip.
pub fn load(path: &Path) -> Result<Image, ElfError> {
    parse(&read(path)?, &path.display().to_string())
}

/// The bytes of the file at `path` (for [`parse`], and for what else reads the ELF: its defmt
/// table).
pub fn read(path: &Path) -> Result<Vec<u8>, ElfError> {
    std::fs::read(path).map_err(|e| ElfError::Read {
        path: path.display().to_string(),
        why: e.to_string(),
    })
}

/// Read an ELF's bytes (`name` for the messages).
pub fn parse(data: &[u8], name: &str) -> Result<Image, ElfError> {
    let kind = object::FileKind::parse(data).map_err(|e| ElfError::NotElf {
        path: name.into(),
        why: e.to_string(),
    })?;
    if kind != object::FileKind::Elf32 {
        let file = object::File::parse(data).map_err(|e| ElfError::NotElf {
            path: name.into(),
            why: e.to_string(),
        })?;
        return Err(ElfError::OtherMachine {
            path: name.into(),
            machine: format!("{:?} ({kind:?})", file.architecture()),
        });
    }
    let elf = ElfFile32::<Endianness>::parse(data).map_err(|e| ElfError::NotElf {
        path: name.into(),
        why: e.to_string(),
    })?;
    let header = elf.elf_header();
    let endian = elf.endian();
    if header.e_machine(endian) != EM_ARM || endian != Endianness::Little {
        return Err(ElfError::OtherMachine {
            path: name.into(),
            machine: format!(
                "{:?}, {:?}-endian",
                elf.architecture(),
                if endian == Endianness::Little {
                    "little"
                } else {
                    "big"
                }
            ),
        });
    }
    let mut flash = Vec::new();
    for ph in elf.elf_program_headers() {
        if ph.p_type(endian) != PT_LOAD || ph.p_filesz(endian) == 0 {
            continue;
        }
        let addr = ph.p_paddr(endian);
        let bytes = ph
            .data(endian, data)
            .map_err(|()| ElfError::NotElf {
                path: name.into(),
                why: "a segment past the file's end".into(),
            })?
            .to_vec();
        let end = u64::from(addr) + bytes.len() as u64;
        if addr < FLASH_BASE || end > u64::from(FLASH_BASE) + u64::from(FLASH_BYTES) {
            return Err(ElfError::OutsideFlash {
                path: name.into(),
                what: "a loadable segment".into(),
                addr,
                bytes: bytes.len(),
            });
        }
        flash.push((addr, bytes));
    }
    let code = elf
        .sections()
        .filter(|s| s.kind() == SectionKind::Text)
        .filter_map(|s| Some((s.address() as u32, s.data().ok()?.to_vec())))
        .collect();
    let rtt = elf
        .symbols()
        .find(|s| s.name() == Ok("_SEGGER_RTT"))
        .map(|s| s.address() as u32);
    let spring_memory = elf
        .symbols()
        .find(|s| s.name().is_ok_and(|n| n.contains("8retained5WORDS")))
        .map(|s| s.address() as u32);
    let word = |at: u32| -> Option<u32> {
        flash.iter().find_map(|(a, b): &(u32, Vec<u8>)| {
            let off = at.checked_sub(*a)? as usize;
            let w = b.get(off..off + 4)?;
            Some(u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        })
    };
    let (sp, reset) = (
        word(FLASH_BASE).unwrap_or(0),
        word(FLASH_BASE + 4).unwrap_or(0),
    );
    let sp_ok = sp > SRAM_BASE && sp <= SRAM_BASE + SRAM_BYTES;
    let reset_ok = reset & 1 == 1 && (FLASH_BASE..FLASH_BASE + FLASH_BYTES).contains(&reset);
    if !(sp_ok && reset_ok) {
        return Err(ElfError::Vectors {
            path: name.into(),
            sp,
            reset,
        });
    }
    Ok(Image {
        flash,
        code,
        rtt,
        spring_memory,
        vectors: (sp, reset),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use object::write::{Object as WObject, Symbol, SymbolSection};
    use object::{Architecture, BinaryFormat, SymbolFlags, SymbolKind, SymbolScope};

    /// A relocatable ARM object has no segments: refused for its vector table.
    #[test]
    fn an_object_without_a_flash_image_is_refused() {
        let mut o = WObject::new(
            BinaryFormat::Elf,
            Architecture::Arm,
            object::Endianness::Little,
        );
        let text = o.add_section(Vec::new(), b".text".to_vec(), SectionKind::Text);
        o.append_section_data(text, &[0x20, 0xBF], 2);
        o.add_symbol(Symbol {
            name: b"_SEGGER_RTT".to_vec(),
            value: 0,
            size: 0,
            kind: SymbolKind::Data,
            scope: SymbolScope::Linkage,
            weak: false,
            section: SymbolSection::Section(text),
            flags: SymbolFlags::None,
        });
        let bytes = o.write().unwrap();
        let err = parse(&bytes, "tiny.o").unwrap_err();
        assert!(matches!(err, ElfError::Vectors { .. }), "{err}");
        assert!(
            err.to_string().contains("does not start an STM32F446"),
            "{err}"
        );
    }

    /// This test's own executable is an ELF for the host: another machine.
    #[test]
    fn an_elf_for_another_machine_is_refused() {
        let exe = std::env::current_exe().unwrap();
        let err = load(&exe).unwrap_err();
        assert!(matches!(err, ElfError::OtherMachine { .. }), "{err}");
        assert!(err.to_string().contains("not the STM32F446"), "{err}");
    }

    #[test]
    fn a_missing_file_and_a_text_file_are_refused() {
        let err = load(Path::new("/nonexistent/thermorph-board")).unwrap_err();
        assert!(err.to_string().contains("cannot read"), "{err}");
        let err = parse(b"not an elf at all", "notes.txt").unwrap_err();
        assert!(matches!(err, ElfError::NotElf { .. }), "{err}");
    }
}
