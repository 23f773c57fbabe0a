//! `qemu-system-arm` (installed when missing), a running QEMU killed when dropped, and its
//! defmt log; the working directory of an emulated device, whose flash file it keeps.
//!
//! **Persistent devices.** The product images keep the model store's flash in the file
//! [`FLASH_FILE`] of QEMU's working directory (semihosting file I/O, written through on every
//! erase and program: `firmware/src/store_flash.rs`). Every device of the tests gets its own
//! directory, `target/qemu/<name>/` ([`device_dir`]), so that its flash is its own; killing
//! QEMU and starting it again on the same directory is a power cycle, deleting the file
//! ([`fresh_device`]) makes a factory-fresh part.

use std::fs::{self, File};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};

use crate::cmd::{describe, is_root, run};

/// `qemu-system-arm`, installed with apt-get when missing and we are root.
pub fn ensure_qemu() -> Result<PathBuf> {
    let found = |p: &str| {
        Command::new(p).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success())
    };
    if found("qemu-system-arm") {
        return Ok(PathBuf::from("qemu-system-arm"));
    }
    if !is_root() {
        bail!(
            "qemu-system-arm is not installed. Install it with `sudo apt-get install -y qemu-system-arm` \
             (Debian/Ubuntu) and run `cargo xtask test` again; `cargo xtask test --no-qemu` skips the firmware tests"
        );
    }
    eprintln!("xtask: qemu-system-arm missing, installing it with apt-get");
    run(Command::new("apt-get").arg("update").arg("-qq"))?;
    run(Command::new("apt-get")
        .args(["install", "-y", "-qq", "qemu-system-arm"])
        .env("DEBIAN_FRONTEND", "noninteractive"))?;
    ensure!(found("qemu-system-arm"), "apt-get ran but qemu-system-arm is still not on PATH");
    Ok(PathBuf::from("qemu-system-arm"))
}

/// Directory of QEMU logs and outputs.
pub fn out_dir(root: &Path) -> Result<PathBuf> {
    let d = root.join("target").join("qemu");
    fs::create_dir_all(&d)?;
    Ok(d)
}

/// The file of a device's working directory that holds its store flash.
pub const FLASH_FILE: &str = "fbg-flash.bin";

/// The working directory of the emulated device `name` (created when missing).
pub fn device_dir(root: &Path, name: &str) -> Result<PathBuf> {
    let d = out_dir(root)?.join(name);
    fs::create_dir_all(&d).with_context(|| format!("creating {}", d.display()))?;
    Ok(d)
}

/// Make the device of `dir` factory-fresh: no flash file, so its next boot finds an erased
/// store.
pub fn fresh_device(dir: &Path) -> Result<()> {
    match fs::remove_file(dir.join(FLASH_FILE)) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(e).with_context(|| format!("deleting {}", dir.join(FLASH_FILE).display()))
        }
        _ => Ok(()),
    }
}

/// The emulated board an image runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Machine {
    /// `mps2-an386` (Cortex-M4F, CMSDK UART0 as serial0): the firmware of `firmware/`.
    Mps2An386,
    /// `netduinoplus2` (STM32F405, USART1 as serial0): the `emulator` build of `firmware/board/`.
    NetduinoPlus2,
}

impl Machine {
    /// QEMU's arguments selecting the machine.
    fn args(self) -> &'static [&'static str] {
        match self {
            Machine::Mps2An386 => &["-machine", "mps2-an386", "-cpu", "cortex-m4"],
            Machine::NetduinoPlus2 => &["-machine", "netduinoplus2"],
        }
    }
}

/// A running QEMU, killed when dropped.
pub struct Qemu {
    child: Child,
    /// The image it runs.
    pub elf: PathBuf,
    /// Its semihosting (defmt) output.
    pub log: PathBuf,
}

impl Drop for Qemu {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

impl Qemu {
    /// Start `elf` on the mps2-an386 with serial0 on `serial` (a QEMU chardev spec).
    pub fn start(qemu: &Path, elf: &Path, serial: &str, log: &Path, extra: &[&str]) -> Result<Qemu> {
        Qemu::start_on(Machine::Mps2An386, qemu, elf, serial, log, extra)
    }

    /// Start `elf` on `machine` with serial0 on `serial` (a QEMU chardev spec).
    pub fn start_on(
        machine: Machine,
        qemu: &Path,
        elf: &Path,
        serial: &str,
        log: &Path,
        extra: &[&str],
    ) -> Result<Qemu> {
        Qemu::start_in(machine, qemu, elf, serial, log, None, &[], extra)
    }

    /// Start `elf` on `machine` with serial0 on `serial` (a QEMU chardev spec), in the working
    /// directory `cwd` (where the image's semihosting files are: a product image's flash file;
    /// `None`: xtask's), `args` its semihosting command line after its name, `extra` more QEMU
    /// options.
    #[allow(clippy::too_many_arguments)]
    pub fn start_in(
        machine: Machine,
        qemu: &Path,
        elf: &Path,
        serial: &str,
        log: &Path,
        cwd: Option<&Path>,
        args: &[&str],
        extra: &[&str],
    ) -> Result<Qemu> {
        ensure!(elf.exists(), "{} is not built", elf.display());
        let stdout = File::create(log).with_context(|| format!("creating {}", log.display()))?;
        let stderr = File::create(log.with_extension("stderr"))?;
        let name = elf.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        // The command line the image reads with SYS_GET_CMDLINE (QEMU 7.2: the `arg`s of
        // -semihosting-config, joined by spaces); a comma would end the option.
        let mut config = format!("enable=on,target=native,arg={name}");
        for a in args {
            ensure!(!a.contains(','), "semihosting argument `{a}` has a comma");
            config.push_str(&format!(",arg={a}"));
        }
        let mut cmd = Command::new(qemu);
        cmd.args(machine.args())
            .args(["-nographic", "-monitor", "none"])
            .args(["-serial", serial])
            .args(["-semihosting-config", &config])
            .args(extra)
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr);
        if let Some(dir) = cwd {
            cmd.current_dir(dir);
        }
        eprintln!("xtask: $ {}", describe(&cmd));
        let child = cmd.spawn().with_context(|| format!("starting {}", qemu.display()))?;
        Ok(Qemu { child, elf: elf.to_path_buf(), log: log.to_path_buf() })
    }

    /// Kill QEMU now (a power cut: the flash file holds whatever the last completed write
    /// left) and wait for it to be gone.
    pub fn kill(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }

    /// Exit status if QEMU has ended.
    pub fn try_exit(&mut self) -> Result<Option<ExitStatus>> {
        Ok(self.child.try_wait()?)
    }

    /// Wait for QEMU to exit by itself, at most `timeout` (then kill it and fail).
    pub fn wait(&mut self, timeout: Duration) -> Result<ExitStatus> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.child.try_wait()? {
                return Ok(s);
            }
            if Instant::now() >= deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                self.show_log();
                bail!("QEMU running {} did not exit within {:?}; killed", self.elf.display(), timeout);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Decode the defmt log next to the raw one (when defmt-print is installed) and print it.
    pub fn show_log(&self) {
        match decode_log(&self.elf, &self.log) {
            Some(text) => eprintln!("xtask: device log ({}):\n{text}", self.log.display()),
            None => eprintln!(
                "xtask: raw defmt log in {} (install defmt-print: `cargo install defmt-print --locked`, then \
                 `defmt-print -e {} < {}`)",
                self.log.display(),
                self.elf.display(),
                self.log.display()
            ),
        }
        if let Ok(err) = fs::read_to_string(self.log.with_extension("stderr")) {
            if !err.trim().is_empty() {
                eprintln!("xtask: QEMU stderr:\n{err}");
            }
        }
    }
}

/// The defmt log decoded by `defmt-print`, when it is installed.
pub fn decode_log(elf: &Path, log: &Path) -> Option<String> {
    let input = File::open(log).ok()?;
    let out = Command::new("defmt-print").arg("-e").arg(elf).stdin(input).output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let _ = fs::write(log.with_extension("log"), &text);
    Some(text)
}
