//! `cargo xtask <task>`: the project's task runner (matklad's xtask pattern), its command line a
//! clap derive as RTIC's and defmt's xtasks have it: every task and flag typed and in `--help`,
//! an unknown one refused.
//!
//! `cargo xtask test` is the README's test command and what CI runs: it installs what it needs
//! (the thumb target comes from `rust-toolchain.toml`; `qemu-system-arm` with apt-get) or stops
//! with a message that says exactly what to install.
//!
//! The modules follow the data: [`cmd`] and [`targets`] (commands, paths, constants) →
//! [`fixtures`] (made by the trainer) → [`signing`] → [`firmware`] (images, emulator, link
//! session) → [`qemu`] (the tests) and [`device_bench`] → [`bench`](mod@bench) → [`slurm`]; [`lint`] and
//! [`python`] (the Python package's wheel and tests) stand beside them. A module uses only modules before it.

use std::process::Command;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};

mod bench;
mod board;
mod cmd;
mod device_bench;
mod elf;
mod firmware;
mod fixtures;
mod lint;
mod python;
mod qemu;
mod signing;
mod slurm;
mod targets;

use cmd::{root, run, step};
use targets::THUMB;

/// The project's tasks.
#[derive(Debug, Parser)]
#[command(name = "cargo xtask", bin_name = "cargo xtask", arg_required_else_help = true)]
struct Cli {
    #[command(subcommand)]
    task: Task,
}

#[derive(Debug, Subcommand)]
enum Task {
    /// lint (fbg-shared's feature matrix on thumbv7em-none-eabihf among it), host tests of the
    /// whole workspace (doctests included), the Python package's tests, firmware build and its
    /// QEMU tests (CI runs this)
    Test {
        /// Skip the firmware build and its QEMU tests (no qemu-system-arm needed)
        #[arg(long)]
        no_qemu: bool,
        /// The fast tier, for iterating: fmt, clippy (default features), the host tests, the
        /// device logic's host tests and the golden vectors on QEMU (CI runs the whole test)
        #[arg(long)]
        fast: bool,
    },
    /// rustfmt --check, clippy on every crate and target (-D warnings) of both workspaces,
    /// fbg-shared's feature matrix, rustdoc (-D warnings), the MSRV, the fuzz target, the deploy
    /// files and the source sizes
    Lint {
        /// Run only these steps (repeat or comma-separate), e.g. `--only sizes`
        #[arg(long, value_enum, value_delimiter = ',')]
        only: Vec<lint::Step>,
    },
    /// Only the firmware: the device logic's host tests, the default-model check, the build
    /// and the QEMU tests
    Qemu {
        /// The long forms of the store tests: all 50 power cuts of the torture test (10 in
        /// `test`) and 1 000 updates in the wear test
        #[arg(long)]
        all: bool,
    },
    /// Firmware flash / static RAM from the ELF and the measured stack peak (the mps2 image),
    /// then the STM32F405 product image's flash against the budget
    Size,
    /// Only the device part of bench: instructions per step at K = 16/32/64 and of the trained
    /// models of other presets under QEMU -icount, and the footprint; writes
    /// target/bench/device.json
    DeviceBench {
        /// Instead, where the default model's step spends its instructions, per function and
        /// per inlined phase (QEMU's exec trace; needs llvm-addr2line); writes
        /// target/bench/device-profile.txt
        #[arg(long)]
        profile: bool,
    },
    /// Every benchmark: host fit times (ours and the scikit-learn peer), host inference
    /// throughput, accuracy peers, band coverage, fleet scaling and the device part; writes
    /// BENCHMARKS.md and BENCHMARKS.json
    Bench(bench::Opts),
    /// The sharded fleet on a single-node Slurm started here (installs slurm-wlm and munge;
    /// needs root; not part of test); writes target/slurm/slurm.json
    Slurm,
    /// The STM32F405 board images (firmware/board/): build for the part and for QEMU
    /// netduinoplus2, print the footprint, run the golden vectors and the link on
    /// netduinoplus2; writes target/bench/board.json
    Board,
    /// The Python package (python/): build its wheel into target/python/venv (made with
    /// `python3 -m venv`, filled from PyPI with python/requirements-test.txt) and run its pytest
    /// suite against the fbg-trainer binary; skipped with a message when python3 is absent
    Python {
        /// Instead of the tests, only the Python part of bench (predict on 1e6 rows against
        /// the scikit-learn peer and `compensate`, fit against `bench-fit --fixed`); writes
        /// target/bench/python.json and puts it into BENCHMARKS.json and BENCHMARKS.md
        #[arg(long)]
        bench: bool,
    },
    /// Make the firmware's test fixtures with fbg-trainer in target/fixtures (the paper preset's
    /// and the strain-pair, temperature-1 and array-8 presets' trained Model-H with golden
    /// vectors)
    Fixtures {
        /// Also copy the paper Model-H (seed 7) to firmware/model/default.fbgm
        #[arg(long)]
        write_default: bool,
    },
}

fn main() -> Result<()> {
    let result = run_task(Cli::parse().task);
    cmd::print_timings();
    result
}

fn run_task(task: Task) -> Result<()> {
    let root = root();
    match task {
        Task::Test { no_qemu, fast } => test(no_qemu, fast),
        Task::Lint { only } => lint::run_steps(&root, &only),
        Task::Qemu { all } => qemu::run_all(&root, all, false),
        Task::Size => {
            let report = device_bench::size(&root)?;
            board::flash_budget(&root, report.footprint.flash)
        }
        Task::DeviceBench { profile: true } => device_bench::profile::run(&root),
        Task::DeviceBench { profile: false } => device_bench::run(&root).map(|_| ()),
        Task::Bench(opts) => bench::run_bench(&root, &opts),
        Task::Slurm => slurm::run_all(&root),
        Task::Board => board::run_all(&root).map(|_| ()),
        Task::Fixtures { write_default } => fixtures_task(write_default),
        Task::Python { bench: false } => python::run_all(&root),
        Task::Python { bench: true } => bench::python::run_alone(&root),
    }
}

fn fixtures_task(write_default: bool) -> Result<()> {
    let root = root();
    let fx = fixtures::ensure(&root)?;
    let dev = fixtures::ensure_device(&root)?;
    println!("{fx:#?}\n{dev:#?}");
    if write_default {
        let path = root.join("firmware/model/default.fbgm");
        cmd::write_atomic(&path, &std::fs::read(&fx.model)?)?;
        println!("wrote {} (the trainer's Model-H, paper preset, seed 7; commit it)", path.display());
    }
    Ok(())
}

/// The host workspace's tests: xtask's own in the profile `cargo xtask` was built with (its
/// dependencies are there already), everything else in release, as the numerics need; the
/// Python package's from Python ([`python::run_all`]).
const HOST_TESTS: [&str; 8] =
    ["test", "--workspace", "--exclude", "xtask", "--exclude", python::PACKAGE, "--release", "--locked"];
/// [`HOST_TESTS`] compiled, not run; the Python wheel's build reuses what it compiles
/// (`lint::wheel`).
/// Every target (the benches and examples too, as `clippy --all-targets` would check them), through
/// [`cmd::with_clippy`].
pub const HOST_TEST_BUILD: [&str; 10] = [
    "test",
    "--workspace",
    "--exclude",
    "xtask",
    "--exclude",
    python::PACKAGE,
    "--release",
    "--locked",
    "--no-run",
    "--all-targets",
];

fn test(skip_qemu: bool, fast: bool) -> Result<()> {
    let root = root();
    ensure_thumb_target()?;
    let venv = (!fast).then(|| python::warm_up(&root));
    // The host workspace's clippy is not a step of its own here: the builds below compile it
    // with clippy (`cmd::with_clippy`), warnings denied.
    if fast {
        lint::run_fast(&root)?;
    } else {
        lint::run_for_tests(&root)?;
    }

    step("host tests: build with clippy (whole workspace, every target, warnings denied)");
    run(cmd::with_clippy(cmd::cargo()).current_dir(&root).args(HOST_TEST_BUILD))?;
    fixtures::trainer_built_by_tests();
    step("host tests: run (doctests included)");
    run(cmd::with_clippy(cmd::cargo()).current_dir(&root).args(HOST_TESTS))?;
    run(cmd::with_clippy(cmd::cargo()).current_dir(&root).args(["test", "-p", "xtask", "--locked"]))?;
    if let Some(venv) = venv {
        let _ = venv.join();
        python::run_all(&root)?;
    }

    if skip_qemu {
        eprintln!("xtask: --no-qemu given, skipping the firmware and its QEMU tests");
    } else if fast {
        qemu::run_fast(&root)?;
    } else {
        qemu::run_all(&root, false, true)?;
    }
    eprintln!("xtask: all {}tests passed", if fast { "fast-tier " } else { "" });
    Ok(())
}

/// The thumb target normally arrives through `rust-toolchain.toml`; make sure it is there.
fn ensure_thumb_target() -> Result<()> {
    let out = Command::new("rustup").args(["target", "list", "--installed"]).current_dir(root()).output();
    match out {
        Ok(o) if String::from_utf8_lossy(&o.stdout).contains(THUMB) => Ok(()),
        Ok(_) => run(Command::new("rustup").args(["target", "add", THUMB]).current_dir(root()))
            .context("install the target with `rustup target add thumbv7em-none-eabihf`"),
        Err(_) => {
            eprintln!("xtask: rustup not found; assuming the thumbv7em-none-eabihf target is installed");
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::*;

    #[test]
    fn the_command_line_is_consistent() {
        Cli::command().debug_assert();
    }

    /// No import circle among xtask's files: at every level of the module tree, the modules
    /// under one parent use each other without a cycle (as the trainer's and `fbg-shared`'s
    /// own tests check theirs).
    #[test]
    fn no_module_cycle_in_xtask() {
        let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        if let Err(e) = fbg_testkit::modules::check(&src) {
            panic!("{e}");
        }
    }

    #[test]
    fn unknown_tasks_and_flags_are_refused_naming_them() {
        for args in [
            &["xtask", "--bogus"][..],
            &["xtask", "test", "--bogus"],
            &["xtask", "bench", "--markdown-only", "--quick"],
        ] {
            let e = Cli::try_parse_from(args).unwrap_err().to_string();
            assert!(e.contains(args[args.len() - 1]), "{args:?}: {e}");
        }
        assert!(matches!(
            Cli::try_parse_from(["xtask", "test"]).unwrap().task,
            Task::Test { no_qemu: false, fast: false }
        ));
        assert!(matches!(
            Cli::try_parse_from(["xtask", "test", "--no-qemu"]).unwrap().task,
            Task::Test { no_qemu: true, fast: false }
        ));
        assert!(matches!(
            Cli::try_parse_from(["xtask", "test", "--fast"]).unwrap().task,
            Task::Test { no_qemu: false, fast: true }
        ));
        let Task::Lint { only } = Cli::try_parse_from(["xtask", "lint", "--only", "sizes,fuzz"]).unwrap().task else {
            panic!("not lint")
        };
        assert_eq!(only, [lint::Step::Sizes, lint::Step::Fuzz]);
        assert!(matches!(Cli::try_parse_from(["xtask", "qemu", "--all"]).unwrap().task, Task::Qemu { all: true }));
        assert!(matches!(Cli::try_parse_from(["xtask", "python"]).unwrap().task, Task::Python { bench: false }));
        assert!(matches!(
            Cli::try_parse_from(["xtask", "python", "--bench"]).unwrap().task,
            Task::Python { bench: true }
        ));
    }
}
