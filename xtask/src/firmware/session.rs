//! A QEMU serving the product image's serial port on a loopback TCP port, and xtask's link
//! client on it; the emulated device keeps its flash in its own directory across power
//! cycles.

use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use fbg_link::LinkClient;

use super::emulator::{device_dir, fresh_device, Machine, Qemu};
use crate::cmd::describe;
use crate::fixtures::Fixtures;

/// A QEMU serving the product image's serial port on a loopback TCP port (QEMU is the
/// server, so that the link client of xtask and `fbg-trainer stream` can take turns), and
/// xtask's link client on it while connected. The device's working directory
/// (`target/qemu/<name>/`) holds its flash file and the defmt log of every image it ran.
pub struct LinkSession {
    /// The emulator (killed on drop).
    pub qemu: Qemu,
    /// The port QEMU listens on.
    pub port: u16,
    /// The device's working directory.
    pub dir: std::path::PathBuf,
    qemu_bin: std::path::PathBuf,
    machine: Machine,
    link: Option<LinkClient<TcpStream>>,
}

/// A loopback port that was free a moment ago.
fn free_port() -> Result<u16> {
    let l = TcpListener::bind("127.0.0.1:0").context("binding a loopback port")?;
    Ok(l.local_addr()?.port())
}

impl LinkSession {
    /// Start the product image `elf` as the factory-fresh device `name` (its flash file
    /// deleted first) and connect to it.
    pub fn start(root: &Path, qemu: &Path, elf: &Path, name: &str) -> Result<LinkSession> {
        LinkSession::start_on(Machine::Mps2An386, root, qemu, elf, name)
    }

    /// Start `elf` on `machine` as the factory-fresh device `name` (its flash file deleted
    /// first) with serial0 on a loopback server port and connect to it.
    pub fn start_on(machine: Machine, root: &Path, qemu: &Path, elf: &Path, name: &str) -> Result<LinkSession> {
        let dir = device_dir(root, name)?;
        fresh_device(&dir)?;
        LinkSession::launch(machine, qemu, elf, &dir, &[], &[])
    }

    /// Start `elf` (mps2-an386) on the device `name` as its flash is (a power-on after
    /// whatever ran there last), `args` on its semihosting command line, and connect to it.
    pub fn resume(root: &Path, qemu: &Path, elf: &Path, name: &str, args: &[&str]) -> Result<LinkSession> {
        LinkSession::launch(Machine::Mps2An386, qemu, elf, &device_dir(root, name)?, args, &[])
    }

    /// A power cycle: QEMU killed at once (the flash file keeps what the last completed erase
    /// or program left), then `elf` started on the same device and machine with `args` (its
    /// semihosting command line) and `extra` (QEMU options) and connected.
    pub fn power_cycle(&mut self, elf: &Path, args: &[&str], extra: &[&str]) -> Result<()> {
        self.link = None;
        self.qemu.kill();
        *self = LinkSession::launch(self.machine, &self.qemu_bin, elf, &self.dir, args, extra)?;
        Ok(())
    }

    /// Start `elf` on `machine` in the device directory `dir` with serial0 on a loopback
    /// server port and connect to it.
    fn launch(
        machine: Machine,
        qemu: &Path,
        elf: &Path,
        dir: &Path,
        args: &[&str],
        extra: &[&str],
    ) -> Result<LinkSession> {
        let stem = elf.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let log = dir.join(format!("{stem}.defmt"));
        let mut last = None;
        // The port is picked free, then bound by QEMU: retry in the unlikely case another
        // process took it in between.
        for _ in 0..3 {
            let port = free_port()?;
            // nodelay: the UART writes a byte at a time; with Nagle on QEMU's socket each answer
            // waits for the client's delayed ACK (≈ 40 ms per sample instead of ≈ 1 ms).
            let serial = format!("tcp:127.0.0.1:{port},server=on,wait=on,nodelay=on");
            let q = Qemu::start_in(machine, qemu, elf, &serial, &log, Some(dir), args, extra)?;
            let mut s = LinkSession {
                qemu: q,
                port,
                dir: dir.to_path_buf(),
                qemu_bin: qemu.to_path_buf(),
                machine,
                link: None,
            };
            match s.connect() {
                Ok(()) => return Ok(s),
                Err(e) => last = Some(e),
            }
        }
        Err(last.unwrap_or_else(|| anyhow::anyhow!("QEMU did not start")))
    }

    /// Connect xtask's link client (QEMU serves one client at a time).
    pub fn connect(&mut self) -> Result<()> {
        let deadline = Instant::now() + Duration::from_secs(20);
        let stream = loop {
            match TcpStream::connect(("127.0.0.1", self.port)) {
                Ok(s) => break s,
                Err(e) => {
                    if let Some(st) = self.qemu.try_exit()? {
                        self.qemu.show_log();
                        bail!("QEMU exited with {st} before serving its serial port ({e})");
                    }
                    ensure!(Instant::now() < deadline, "QEMU does not serve 127.0.0.1:{} after 20 s: {e}", self.port);
                    std::thread::sleep(Duration::from_millis(20));
                }
            }
        };
        stream.set_read_timeout(Some(Duration::from_secs(15)))?;
        stream.set_nodelay(true)?;
        self.link = Some(LinkClient::new(stream));
        eprintln!("xtask: connected to the device's serial port on 127.0.0.1:{}", self.port);
        Ok(())
    }

    /// Disconnect xtask's client (so that another client can connect).
    pub fn disconnect(&mut self) -> Result<()> {
        if let Some(link) = self.link.take() {
            ensure!(
                link.malformed_from_device() == 0,
                "the device sent {} malformed frames",
                link.malformed_from_device()
            );
        }
        // Give QEMU a moment to notice and listen again.
        std::thread::sleep(Duration::from_millis(50));
        Ok(())
    }

    /// The connected client.
    pub fn link(&mut self) -> Result<&mut LinkClient<TcpStream>> {
        self.link.as_mut().context("not connected to the device")
    }

    /// Fail with the device log when QEMU has exited (a crash shows as an exit).
    pub fn check_alive(&mut self) -> Result<()> {
        if let Some(st) = self.qemu.try_exit()? {
            self.qemu.show_log();
            bail!("the firmware exited with {st} while serving");
        }
        Ok(())
    }

    /// Run `fbg-trainer stream` against the device (xtask's client disconnected meanwhile) and
    /// return its JSON report.
    pub fn trainer_stream(&mut self, fx: &Fixtures, model: &Path, extra: &[&str]) -> Result<serde_json::Value> {
        self.disconnect()?;
        let mut cmd = Command::new(&fx.trainer);
        cmd.args(["stream", "--model"])
            .arg(model)
            .arg("--data")
            .arg(&fx.data)
            .args(["--port", &self.port.to_string(), "--json"])
            .args(extra)
            .stdin(Stdio::null())
            .stderr(Stdio::inherit());
        eprintln!("xtask: $ {}", describe(&cmd));
        let out = cmd.output().with_context(|| format!("starting {}", fx.trainer.display()))?;
        if !out.status.success() {
            let _ = self.check_alive();
            bail!("`fbg-trainer stream` failed with {} (its report is above)", out.status);
        }
        let report: serde_json::Value =
            serde_json::from_slice(&out.stdout).context("`fbg-trainer stream --json` printed no JSON report")?;
        self.connect()?;
        Ok(report)
    }
}
