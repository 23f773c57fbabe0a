//! Bounded waits and bounded memory (issue 28, items 5, 7 and 8b): a trickling device times
//! out at the answer deadline, an overlong line is refused as it is read, a huge cell is cut
//! in the message, `compensate` streams its rows to the same bytes as before, and a model
//! that cannot be loaded is named.

use std::io::Write;
use std::process::Command;
use std::time::{Duration, Instant};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fbg-trainer"))
}

fn run(cmd: &mut Command) -> (bool, String, String) {
    let o = cmd.output().unwrap();
    (o.status.success(), String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// A fake device on a local port that answers every connection by trickling one byte every
/// 200 ms (never a complete frame) until the client goes away.
fn trickling_device() -> (u16, std::thread::JoinHandle<()>) {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let h = std::thread::spawn(move || {
        let (mut sock, _) = listener.accept().unwrap();
        for _ in 0..300 {
            std::thread::sleep(Duration::from_millis(200));
            if sock.write_all(&[0x42]).is_err() {
                return;
            }
        }
    });
    (port, h)
}

#[test]
fn device_status_times_out_on_a_trickling_device_at_the_deadline() {
    let (port, dev) = trickling_device();
    let t0 = Instant::now();
    let (ok, _, err) =
        run(bin().args(["device", "status", "--timeout", "2", "--port"]).arg(port.to_string()));
    let took = t0.elapsed();
    assert!(!ok, "{err}");
    assert!(err.contains("timed out") && err.contains("within 2.000 s"), "{err}");
    // Before: each trickled byte restarted a per-read time-out and this waited a minute.
    assert!(took >= Duration::from_secs(2) && took < Duration::from_millis(3000), "{took:?}: {err}");
    dev.join().unwrap();
}
