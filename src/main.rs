//! `brdfwave` command line: render scenes on the GPU (Vulkan) or the CPU reference, compare
//! images, and measure the reflectance models.
//!
//! This file parses the arguments and dispatches; each command is a module of `cmd/` with its
//! clap arguments and its `run`.

use anyhow::{Context as _, Result};
use clap::{Parser, Subcommand};

/// `eprintln!` that never panics: a warning that cannot be written (stderr full or closed) is
/// dropped and the work goes on (std's version panics). `out!` and `outln!` write the
/// command's data to stdout and return an error naming it when that fails: a full disk is an
/// error exit, never a panic, and never a silent success. Both escape the control characters of
/// what they print but its layout (`brdfwave::errors::terminal_safe`): a file name or a value
/// with an escape sequence does not reach the terminal as one. Defined before `mod cmd` so
/// that every command module has them.
macro_rules! eprintln {
    () => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr());
    }};
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let text = format!($($arg)*);
        let _ = writeln!(std::io::stderr(), "{}", brdfwave::errors::terminal_safe(&text));
    }};
}
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::write_stdout(format_args!($($arg)*))
    };
}
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

mod cmd;

fn write_stdout(args: std::fmt::Arguments<'_>) -> Result<()> {
    use std::io::Write as _;
    let text = args.to_string();
    let mut o = std::io::stdout().lock();
    o.write_all(brdfwave::errors::terminal_safe(&text).as_bytes())
        .and_then(|_| o.flush())
        .context("cannot write to standard output")
}

#[derive(Parser)]
#[command(
    name = "brdfwave",
    // The package version, the commit and whether the code had uncommitted changes.
    version = &*String::leak(brdfwave::film::code_version()),
    about = "Vulkan wavefront path tracer for the survey's surface models"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file to one or more images (.exr linear, .png sRGB).
    Render(cmd::render::RenderArgs),
    /// Write a scene in another renderer's format: Mitsuba 3 XML, with its meshes as OBJ files.
    Convert(cmd::convert::ConvertArgs),
    /// Merge partial films (.bwfilm outputs of `render`) into one image: the parts must come
    /// from the same scene, settings and program version and cover every pixel and sample once.
    Merge(cmd::merge::MergeArgs),
    /// Compare a test image with a reference: RMSE, relMSE (pbrt) and FLIP.
    Diff(cmd::diff::DiffArgs),
    /// Run time against error: every configuration renders the scene progressively, taking
    /// turns, compared with a reference after each pass; writes bench.csv, bench.png, bench.md.
    Bench(cmd::bench::BenchArgs),
    /// Time the BVH traversal alone: a scene's camera, bounce and shadow rays through
    /// brdfwave's traversal and through the Vulkan driver's own ray queries, on one device.
    Rays(cmd::rays::RaysArgs),
    /// List the Vulkan devices.
    Devices,
    /// Evaluate, plot and measure reflectance models.
    Brdf {
        #[command(subcommand)]
        command: cmd::brdf::BrdfCommand,
    },
    /// Randomized numerical-stability checks within a time budget (see src/stress/).
    Stress(cmd::stress::StressArgs),
    /// Check (or with --write, rewrite) the generated option reference in docs/cli/*.md.
    #[command(hide = true)]
    Docs(cmd::docs::DocsArgs),
}

fn main() {
    // Rust ignores SIGPIPE, so printing to a closed pipe (`brdfwave diff a b | head`) would
    // panic; restore the default action and end quietly, as other command-line tools do.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    brdfwave::outfile::remove_temporaries_on_signal();
    // Every file a command reads is remembered, and no output may replace one.
    brdfwave::infile::record_inputs();
    // A negative number is a value, never an option: `--spp -1` gave clap's tip to write
    // `-- -1`, which does not work; now it is refused as an invalid value of --spp.
    let cli = {
        use clap::{CommandFactory, FromArgMatches};
        let cmd = Cli::command().mut_subcommands(|c| {
            c.allow_negative_numbers(true)
                .mut_subcommands(|c| c.allow_negative_numbers(true))
        });
        Cli::from_arg_matches(&cmd.get_matches()).unwrap_or_else(|e| e.exit())
    };
    let result = match cli.command {
        Command::Render(args) => cmd::render::run(args),
        Command::Convert(args) => cmd::convert::run(args),
        Command::Merge(args) => cmd::merge::run(args),
        Command::Diff(args) => cmd::diff::run(args),
        Command::Bench(args) => cmd::bench::run(args),
        Command::Rays(args) => cmd::rays::run(args),
        Command::Devices => cmd::devices::run(),
        Command::Brdf { command } => cmd::brdf::run(command),
        Command::Stress(args) => cmd::stress::run(args),
        Command::Docs(args) => cmd::docs::run(args, {
            use clap::CommandFactory;
            Cli::command()
        }),
    };
    if let Err(e) = result {
        eprintln!("error: {}", brdfwave::errors::chain(&e));
        std::process::exit(1);
    }
}
