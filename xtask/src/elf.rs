//! Just enough ELF32 (little-endian) reading to measure a firmware image: section headers and
//! their names, and the symbol table (names, addresses, sizes). No external tool (arm-none-eabi-size,
//! llvm-nm) needed.

use std::path::Path;

use anyhow::{bail, ensure, Context, Result};

const SHF_WRITE: u32 = 0x1;
const SHF_ALLOC: u32 = 0x2;
const SHT_NOBITS: u32 = 8;
const SHT_SYMTAB: u32 = 2;

/// One section header.
#[derive(Clone, Debug)]
pub struct Section {
    /// Name (`.text`, `.bss`, ...).
    pub name: String,
    /// `sh_type`.
    pub kind: u32,
    /// `sh_flags`.
    pub flags: u32,
    /// Size in bytes.
    pub size: u32,
    /// `sh_offset`: where its bytes are in the file.
    pub offset: u32,
    /// `sh_link`: for a symbol table, the index of its string table.
    pub link: u32,
}

impl Section {
    /// Occupies memory at run time.
    pub fn alloc(&self) -> bool {
        self.flags & SHF_ALLOC != 0
    }
    /// Lives in RAM (writable).
    pub fn writable(&self) -> bool {
        self.flags & SHF_WRITE != 0
    }
    /// Has bytes in the image (not .bss-like), so it is stored in flash.
    pub fn has_bytes(&self) -> bool {
        self.kind != SHT_NOBITS
    }
}

fn u16_at(b: &[u8], at: usize) -> Result<u16> {
    let s = b.get(at..at + 2).context("ELF truncated")?;
    Ok(u16::from_le_bytes([s[0], s[1]]))
}

fn u32_at(b: &[u8], at: usize) -> Result<u32> {
    let s = b.get(at..at + 4).context("ELF truncated")?;
    Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// Section headers of an ELF32 LE image.
pub fn sections(bytes: &[u8]) -> Result<Vec<Section>> {
    ensure!(bytes.get(..4) == Some(b"\x7fELF".as_slice()), "not an ELF file");
    ensure!(bytes.get(4) == Some(&1) && bytes.get(5) == Some(&1), "not a 32-bit little-endian ELF");
    let shoff = u32_at(bytes, 0x20)? as usize;
    let shentsize = u16_at(bytes, 0x2E)? as usize;
    let shnum = u16_at(bytes, 0x30)? as usize;
    let shstrndx = u16_at(bytes, 0x32)? as usize;
    ensure!(shentsize >= 40, "odd section header size {shentsize}");
    let hdr = |i: usize| shoff + i * shentsize;
    let str_off = u32_at(bytes, hdr(shstrndx) + 16)? as usize;
    let mut out = Vec::with_capacity(shnum);
    for i in 0..shnum {
        let h = hdr(i);
        let name_off = str_off + u32_at(bytes, h)? as usize;
        let tail = bytes.get(name_off..).context("section name outside the file")?;
        let end = tail.iter().position(|&c| c == 0).unwrap_or(tail.len());
        out.push(Section {
            name: String::from_utf8_lossy(&tail[..end]).into_owned(),
            kind: u32_at(bytes, h + 4)?,
            flags: u32_at(bytes, h + 8)?,
            size: u32_at(bytes, h + 20)?,
            offset: u32_at(bytes, h + 16)?,
            link: u32_at(bytes, h + 24)?,
        });
    }
    if out.is_empty() {
        bail!("ELF without sections");
    }
    Ok(out)
}

/// One entry of the symbol table: its name as stored (mangled), address and size.
#[derive(Clone, Debug)]
pub struct Symbol {
    pub name: String,
    pub addr: u32,
    pub size: u32,
}

/// The named entries of the symbol table (`.symtab`) of an ELF32 LE image.
pub fn symbols(bytes: &[u8]) -> Result<Vec<Symbol>> {
    let secs = sections(bytes)?;
    let symtab = secs.iter().find(|s| s.kind == SHT_SYMTAB).context("the image has no symbol table")?;
    let strtab = secs.get(symtab.link as usize).context("the symbol table's string table is missing")?;
    let strings = bytes
        .get(strtab.offset as usize..(strtab.offset + strtab.size) as usize)
        .context("string table outside the file")?;
    let mut out = Vec::new();
    for at in (symtab.offset..symtab.offset + symtab.size).step_by(16) {
        let name = u32_at(bytes, at as usize)? as usize;
        let tail = strings.get(name..).context("symbol name outside the string table")?;
        let end = tail.iter().position(|&c| c == 0).unwrap_or(tail.len());
        if end > 0 {
            out.push(Symbol {
                name: String::from_utf8_lossy(&tail[..end]).into_owned(),
                addr: u32_at(bytes, at as usize + 4)?,
                size: u32_at(bytes, at as usize + 8)?,
            });
        }
    }
    Ok(out)
}

/// The names in the symbol table (`.symtab`) of an ELF32 LE image, as stored (mangled).
pub fn symbol_names(bytes: &[u8]) -> Result<Vec<String>> {
    Ok(symbols(bytes)?.into_iter().map(|s| s.name).collect())
}

/// The symbols of `core::fmt` (the formatting machinery: `Formatter`, `Display`/`Debug`
/// implementations, `write_fmt`) in the image at `path`, mangled: in both manglings the path
/// `core::fmt` is the segment `4core3fmt` (v0, legacy `_ZN4core3fmt…`) or `core..fmt` (a
/// legacy `<T as core::fmt::Display>`). `core::panicking::panic_fmt` is not among them: it
/// passes a message on without formatting it.
pub fn core_fmt_symbols(path: &Path) -> Result<Vec<String>> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let mut found: Vec<String> =
        symbol_names(&bytes)?.into_iter().filter(|n| n.contains("4core3fmt") || n.contains("core..fmt")).collect();
    found.sort();
    found.dedup();
    Ok(found)
}

/// Fail when the image at `path` (`what` names it) links `core::fmt` ([`core_fmt_symbols`]):
/// the product carries no formatting code (its panic paths, the usual way in, are written out).
pub fn ensure_no_core_fmt(path: &Path, what: &str) -> Result<()> {
    let found = core_fmt_symbols(path)?;
    ensure!(
        found.is_empty(),
        "{what} ({}) links core::fmt ({} symbols: {}); find the panic path or formatting that brings it in \
         (`llvm-nm -C` on the image, then who calls core::panicking::*) and write it without",
        path.display(),
        found.len(),
        found.iter().take(8).cloned().collect::<Vec<_>>().join(", ")
    );
    eprintln!("xtask: {what}: no core::fmt symbols in the image");
    Ok(())
}

/// Flash and static RAM of an image.
#[derive(Clone, Debug, Default)]
pub struct Footprint {
    /// Bytes stored in flash: code, read-only data, vector table, .data initialisers.
    pub flash: u64,
    /// Bytes of RAM reserved statically: .data + .bss + .uninit.
    pub ram_static: u64,
    /// Per allocated section: (name, size, in RAM).
    pub sections: Vec<(String, u64, bool)>,
}

/// Measure the image at `path`.
pub fn footprint(path: &Path) -> Result<Footprint> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let mut fp = Footprint::default();
    for s in sections(&bytes)?.into_iter().filter(|s| s.alloc() && s.size > 0) {
        if s.has_bytes() {
            fp.flash += s.size as u64;
        }
        if s.writable() {
            fp.ram_static += s.size as u64;
        }
        fp.sections.push((s.name.clone(), s.size as u64, s.writable()));
    }
    Ok(fp)
}
