//! `mdas` command-line interface. Run `mdas --help`.

mod cli;

use clap::Parser;
use cli::{Cli, Command};
use std::process::ExitCode;

fn main() -> ExitCode {
    quiet_headless_vulkan();
    mdas::atomic::guard_inputs();
    if let Err(e) = mdas::atomic::install_interrupt_cleanup() {
        eprintln!("warning: {e:#}; an interrupt may leave hidden partial outputs");
    }
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Mesa's Vulkan window-system code prints "error: XDG_RUNTIME_DIR is
/// invalid or not set" on headless machines although mdas needs no window
/// system. Give it a private, empty runtime directory when none is set.
/// Runs first in `main`, before any thread exists, as `set_var` requires.
fn quiet_headless_vulkan() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let user = std::env::var("USER").unwrap_or_default();
    let dir = std::env::temp_dir().join(format!("mdas-xdg-runtime-{user}"));
    #[cfg(unix)]
    {
        use std::os::unix::fs::DirBuilderExt;
        let made = std::fs::DirBuilder::new().mode(0o700).create(&dir);
        if made.is_ok() || dir.is_dir() {
            std::env::set_var("XDG_RUNTIME_DIR", &dir);
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let ui = cli::Ui {
        json: cli.json,
        quiet: cli.quiet,
    };
    match cli.command {
        // A sequence (`--frames`) reuses render's arguments and integrator.
        Command::Render(args) if args.frames.is_some() => cli::frames::run(args, ui),
        Command::Render(args) => cli::render::run(args, ui),
        Command::Reference(args) => cli::reference::run(args, ui),
        Command::Merge(args) => cli::reference::merge(args, ui),
        Command::Compare(args) => cli::compare::run(args, ui),
        Command::Sweep(args) => cli::sweep::run(args, ui),
        Command::Tune(args) => cli::tune::run(args, ui),
        Command::Bench(args) => cli::bench::run(args, ui),
        Command::Scene(args) => cli::scene::run(args, ui),
        Command::View(args) => cli::view::run(args, ui),
        Command::Completions { shell } => {
            use clap::CommandFactory;
            use std::io::Write;
            // Into a buffer first: clap_complete panics on a failed write
            // (a closed pipe), where a write of our own returns the error.
            let mut script = Vec::new();
            clap_complete::generate(shell, &mut Cli::command(), "mdas", &mut script);
            std::io::stdout().write_all(&script)?;
            Ok(())
        }
        Command::Man => {
            use clap::CommandFactory;
            clap_mangen::Man::new(Cli::command()).render(&mut std::io::stdout())?;
            Ok(())
        }
        Command::Info => {
            let gpu = mdas::gpu::Gpu::shared()?;
            ui.result(format!(
                "mdas {}\n{}\n",
                env!("CARGO_PKG_VERSION"),
                gpu.describe()
            ));
            ui.json(&gpu.summary())
        }
    }
}
