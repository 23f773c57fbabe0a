//! `cargo xtask device-bench --profile`: where the default model's step spends its
//! instructions, function by function and phase by phase (docs/firmware/measurements.md, "The
//! step profiled per phase").
//!
//! Timing parts of the step with SysTick would move the code it times, so this reads the
//! emulator's trace instead. The bench image (capacity 32; the device fixtures' pack, the
//! trainer's default model first) runs under `qemu-system-arm -singlestep -d exec,nochain
//! -dfilter …`: QEMU logs the address of every instruction executed in the kernel's step and in
//! the code it can call (the symbols of `fbg_shared`, `libm` and the compiler's builtins). The
//! default model's steps 201 to 997 (its second `regular` run, the stream settled) are cut out
//! at the step's entry address; each address is attributed to its function (the symbol table)
//! and, inside the step, to the inlined call chain `llvm-addr2line -f -i` reads from the image's
//! debug info (a phase is the function the step's body inlined at that address). It measures
//! and asserts nothing: the step's cost against its target is the bench's, under `-icount`.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, ensure, Context, Result};

use crate::cmd::{step, write_atomic};
use crate::elf::{self, Symbol};
use crate::firmware::{self, emulator};
use crate::{fixtures, signing};

/// The default model's steps profiled, as step indices of the image's first model: its second
/// `regular` run is steps 200 to 999; an edge is left on each side.
const FIRST: usize = 201;
const END: usize = 998;

/// Crates whose code the step can run (matched in the mangled symbol names).
const TRACED: [&str; 5] = ["fbg_firmware_kernel", "fbg_shared", "libm", "compiler_builtins", "__aeabi"];

/// Profile the default model's step; prints the tables and writes them to
/// `target/bench/device-profile.txt`.
pub fn run(root: &Path) -> Result<()> {
    let qemu = emulator::ensure_qemu()?;
    let a2l = addr2line()?;
    step("device profile: the bench image, capacity 32");
    let fx = fixtures::ensure(root)?;
    let device = fixtures::ensure_device(root)?;
    let pack = &device.bench_packs.iter().find(|(c, _)| *c == 32).context("no bench pack for capacity 32")?.1;
    signing::bench_signed(root, &fx)?;
    let image = firmware::build_spectrum(root, 32, Some(pack), &["bench"])?.join("bench");
    let mut text: Vec<Symbol> = elf::symbols(&std::fs::read(&image)?)?
        .into_iter()
        .filter(|s| s.size > 0 && s.addr < 0x2000_0000)
        .map(|s| Symbol { addr: s.addr & !1, ..s })
        .collect();
    text.sort_by_key(|s| s.addr);
    let entry = text
        .iter()
        .find(|s| s.name.contains("19fbg_firmware_kernel4step"))
        .context("the bench image has no fbg_firmware_kernel::step")?
        .addr;

    step("device profile: QEMU -singlestep -d exec (the default model's steps)");
    let (counts, steps) = trace(&qemu, &image, &text, entry)?;
    let total: u64 = counts.values().sum();
    let per = |n: u64| n as f64 / steps as f64;

    let mut report = String::new();
    writeln!(
        report,
        "the default model's step, steps {FIRST}–{} ({steps} steps): {:.1} instructions per step",
        END - 1,
        per(total)
    )?;
    writeln!(report, "\nper function (the step and what it calls out of line):")?;
    let mut by_fn: HashMap<u32, u64> = HashMap::new();
    for (&pc, &n) in &counts {
        if let Some(s) = symbol_of(&text, pc) {
            *by_fn.entry(s.addr).or_default() += n;
        }
    }
    let names = functions(&a2l, &image, &by_fn.keys().copied().collect::<Vec<_>>())?;
    for (addr, n) in sorted(by_fn) {
        writeln!(report, "{:>9.1}  {}", per(n), names.get(&addr).map_or("?", |s| s.as_str()))?;
    }
    writeln!(report, "\nthe kernel's step, per phase (the function inlined into the step at each address):")?;
    let step_end = symbol_of(&text, entry).map_or(entry, |s| s.addr + s.size);
    let in_step: Vec<u32> = counts.keys().copied().filter(|&pc| pc >= entry && pc < step_end).collect();
    let chains = inline_chains(&a2l, &image, &in_step)?;
    let mut by_phase: HashMap<String, u64> = HashMap::new();
    for pc in in_step {
        *by_phase.entry(phase(chains.get(&pc).map_or(&[][..], |c| c.as_slice()))).or_default() += counts[&pc];
    }
    for (name, n) in sorted(by_phase) {
        writeln!(report, "{:>9.1}  {name}", per(n))?;
    }
    print!("{report}");
    let out = root.join("target").join("bench").join("device-profile.txt");
    std::fs::create_dir_all(out.parent().context("no parent")?)?;
    write_atomic(&out, report.as_bytes())?;
    eprintln!("xtask: wrote {}", out.display());
    Ok(())
}

/// Run the image under QEMU's exec trace, filtered to the traced crates' symbols; count each
/// address executed during the profiled steps. Returns the counts and the steps counted.
fn trace(qemu: &Path, image: &Path, text: &[Symbol], entry: u32) -> Result<(HashMap<u32, u64>, usize)> {
    let ranges: Vec<String> = text
        .iter()
        .filter(|s| TRACED.iter().any(|k| s.name.contains(k)))
        .map(|s| format!("0x{:x}+0x{:x}", s.addr, s.size))
        .collect();
    let mut child = Command::new(qemu)
        .args(["-machine", "mps2-an386", "-cpu", "cortex-m4", "-nographic", "-monitor", "none"])
        .args(["-serial", "null", "-semihosting-config", "enable=on,target=native"])
        .args(["-singlestep", "-d", "exec,nochain", "-D", "/dev/stderr", "-dfilter", &ranges.join(",")])
        .arg("-kernel")
        .arg(image)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .context("starting qemu-system-arm")?;
    let log = child.stderr.take().context("no QEMU log")?;
    let mut counts: HashMap<u32, u64> = HashMap::new();
    let mut entries = 0usize;
    for line in BufReader::new(log).lines() {
        let Some(pc) = traced_pc(&line?) else { continue };
        if pc == entry {
            entries += 1;
            if entries > END {
                break;
            }
        }
        if entries > FIRST {
            *counts.entry(pc).or_default() += 1;
        }
    }
    let _ = child.kill();
    let _ = child.wait();
    ensure!(entries > END, "the trace ended after {entries} steps of the first model (expected more than {END})");
    Ok((counts, END - FIRST))
}

/// The guest address of a `-d exec` line (`Trace 0: 0x… [flags/PC/…] name`).
fn traced_pc(line: &str) -> Option<u32> {
    let rest = line.strip_prefix("Trace ")?;
    let fields = rest.split_once('[')?.1.split_once(']')?.0;
    u32::from_str_radix(fields.split('/').nth(1)?, 16).ok()
}

fn symbol_of(text: &[Symbol], pc: u32) -> Option<&Symbol> {
    let i = text.partition_point(|s| s.addr <= pc).checked_sub(1)?;
    text.get(i).filter(|s| pc < s.addr + s.size)
}

/// Largest first.
fn sorted<K>(m: HashMap<K, u64>) -> Vec<(K, u64)> {
    let mut v: Vec<(K, u64)> = m.into_iter().collect();
    v.sort_by_key(|e| std::cmp::Reverse(e.1));
    v
}

/// `llvm-addr2line`, which reads an Arm image's DWARF with its inlining (GNU addr2line of a
/// host binutils does not read Arm images).
fn addr2line() -> Result<PathBuf> {
    for name in ["llvm-addr2line", "llvm-addr2line-19", "llvm-addr2line-16", "llvm-addr2line-14"] {
        let ok = Command::new(name).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status();
        if ok.is_ok_and(|s| s.success()) {
            return Ok(PathBuf::from(name));
        }
    }
    bail!("the profile needs llvm-addr2line: install LLVM's tools (Debian/Ubuntu: `apt-get install llvm`)")
}

/// `llvm-addr2line -f -C -a [-i]` on `addrs`: for each address, its frames (function,
/// location), innermost first.
fn frames(a2l: &Path, image: &Path, addrs: &[u32], inlined: bool) -> Result<HashMap<u32, Vec<(String, String)>>> {
    let mut c = Command::new(a2l);
    c.args(["-f", "-C", "-a", "-e"]).arg(image);
    if inlined {
        c.arg("-i");
    }
    let mut child = c.stdin(Stdio::piped()).stdout(Stdio::piped()).spawn().context("running llvm-addr2line")?;
    let input: String = addrs.iter().map(|a| format!("0x{a:x}\n")).collect();
    child.stdin.take().context("no stdin")?.write_all(input.as_bytes())?;
    let out = child.wait_with_output()?;
    ensure!(out.status.success(), "llvm-addr2line failed");
    let text = String::from_utf8_lossy(&out.stdout);
    let mut map: HashMap<u32, Vec<(String, String)>> = HashMap::new();
    let mut current = None;
    let mut lines = text.lines();
    while let Some(l) = lines.next() {
        if let Some(hex) = l.strip_prefix("0x") {
            current = u32::from_str_radix(hex, 16).ok();
        } else if let Some(a) = current {
            let location = lines.next().unwrap_or_default().to_string();
            map.entry(a).or_default().push((readable(l), location));
        }
    }
    Ok(map)
}

/// A Rust legacy-mangled name as `llvm-addr2line -C` leaves it, made readable: the hash
/// dropped and the `$LT$`-style escapes decoded.
fn readable(name: &str) -> String {
    let name = match name.rsplit_once("::h") {
        Some((head, hash)) if hash.len() == 16 && hash.bytes().all(|b| b.is_ascii_hexdigit()) => head,
        _ => name,
    };
    let mut s = name.replace("::_$", "::$").replace("..", "::");
    for (from, to) in
        [("$LT$", "<"), ("$GT$", ">"), ("$u20$", " "), ("$C$", ","), ("$RF$", "&"), ("$u7b$", "{"), ("$u7d$", "}")]
    {
        s = s.replace(from, to);
    }
    s
}

/// Each function's name (demangled), by its start address.
fn functions(a2l: &Path, image: &Path, addrs: &[u32]) -> Result<HashMap<u32, String>> {
    Ok(frames(a2l, image, addrs, false)?
        .into_iter()
        .filter_map(|(a, f)| f.into_iter().next().map(|(name, _)| (a, name)))
        .collect())
}

/// Each address's inlined call chain, innermost first, as the functions' last path segments.
fn inline_chains(a2l: &Path, image: &Path, addrs: &[u32]) -> Result<HashMap<u32, Vec<String>>> {
    Ok(frames(a2l, image, addrs, true)?
        .into_iter()
        .map(|(a, f)| (a, f.into_iter().map(|(name, _)| short(&name)).collect()))
        .collect())
}

/// The last path segment of a demangled name, generics and hash dropped.
fn short(name: &str) -> String {
    let base = name.split('<').next().unwrap_or(name).trim_end_matches(':');
    let tail = name.rsplit("::").next().unwrap_or(name);
    if tail.contains('>') || tail.is_empty() { base.rsplit("::").next().unwrap_or(base) } else { tail }.to_string()
}

/// The phase of an address: the function the step's body (`step_shaped`) inlined there,
/// followed inside the step's parts (`enter`, `residual`, `leave`) down to what they inlined.
fn phase(chain: &[String]) -> String {
    let Some(mut at) = chain.iter().position(|f| f == "step_shaped") else {
        return "(the step's entry and exit)".to_string();
    };
    let mut path: Vec<&str> = Vec::new();
    while let Some(f) = at.checked_sub(1).and_then(|i| chain.get(i)) {
        path.push(f);
        at -= 1;
        if !["enter", "residual", "leave"].contains(&f.as_str()) {
            break;
        }
    }
    if path.is_empty() {
        "step_shaped".to_string()
    } else {
        path.join("/")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trace_line_gives_its_guest_address() {
        let line = "Trace 0: 0x7f7d3c35c240 [00800400/000054ec/00000010/ff000201] _ZN19fbg_firmware_kernel4step17hE";
        assert_eq!(traced_pc(line), Some(0x54ec));
        assert_eq!(traced_pc("Linking TBs 0x1 [000054ec] index 0"), None);
    }

    #[test]
    fn a_phase_is_what_the_step_inlined() {
        let chain = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(phase(&chain(&["update", "admits", "let_in", "enter", "step_shaped", "step"])), "enter/let_in");
        assert_eq!(phase(&chain(&["rbf_inputs", "step_shaped", "step"])), "rbf_inputs");
        assert_eq!(phase(&chain(&["step"])), "(the step's entry and exit)");
        assert_eq!(phase(&chain(&["enter", "step_shaped"])), "enter");
        assert_eq!(phase(&chain(&["sqrt", "finish", "leave", "residual", "step_shaped"])), "residual/leave/finish");
        assert_eq!(short("fbg_shared::compensator::step::<impl fbg_shared::X<F, _>>::step_shaped"), "step_shaped");
        let mangled = "fbg_shared::compensator::step::_$LT$impl$u20$fbg_shared..X$LT$F$C$_$GT$$GT$::step_shaped::h23889720f94916cb";
        assert_eq!(readable(mangled), "fbg_shared::compensator::step::<impl fbg_shared::X<F,_>>::step_shaped");
        assert_eq!(short(&readable(mangled)), "step_shaped");
    }
}
