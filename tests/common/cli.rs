//! The `brdfwave` binary in a subprocess, as the command-line tests run it: in the repository
//! root, with a test file's own scratch folder and environment.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// How one test file runs the binary.
pub struct Cli {
    /// The scratch folder is `brdfwave-TAG-PID` in the system's temporary folder.
    pub tag: &'static str,
    /// Whether `BRDFWAVE_CACHE_DIR` is the scratch folder's `cache` (else it is inherited).
    pub own_cache: bool,
    /// Variables removed from the environment (`LP_NUM_THREADS`, say).
    pub env_remove: &'static [&'static str],
}

impl Cli {
    /// `name` in the test file's scratch folder ([`super::scratch`]).
    pub fn tmp(&self, name: &str) -> PathBuf {
        super::scratch(self.tag).join(name)
    }

    /// Runs `brdfwave ARGS`; fails the test when it panicked.
    pub fn run(&self, args: &[&str]) -> Output {
        let mut c = Command::new(env!("CARGO_BIN_EXE_brdfwave"));
        c.args(args).current_dir(super::repo());
        if self.own_cache {
            c.env("BRDFWAVE_CACHE_DIR", self.tmp("cache"));
        }
        for v in self.env_remove {
            c.env_remove(v);
        }
        let out = c.output().expect("run brdfwave");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            !stderr.contains("panicked"),
            "brdfwave {args:?} panicked:\n{stderr}"
        );
        out
    }

    /// Runs `args`; asserts the exit status; returns stdout and stderr.
    #[track_caller]
    pub fn status(&self, args: &[&str], code: i32) -> (String, String) {
        let out = self.run(args);
        let (o, e) = (
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        );
        assert_eq!(
            out.status.code(),
            Some(code),
            "{args:?}\nstdout:\n{o}\nstderr:\n{e}"
        );
        (o, e)
    }

    /// Runs `args`, which must succeed; returns its stdout.
    pub fn ok(&self, args: &[&str]) -> String {
        let out = self.run(args);
        assert!(
            out.status.success(),
            "brdfwave {args:?} failed ({}):\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).expect("utf-8 stdout")
    }

    /// Runs a command that must fail; returns its stderr.
    pub fn fails(&self, args: &[&str]) -> String {
        let out = self.run(args);
        assert_eq!(
            out.status.code(),
            Some(1),
            "brdfwave {args:?} should fail with status 1; stdout:\n{}\nstderr:\n{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stderr).into_owned()
    }

    /// Runs a command that must fail with a message naming `needle`; returns its stderr.
    #[track_caller]
    pub fn fails_naming(&self, args: &[&str], needle: &str) -> String {
        self.fails_naming_all(args, &[needle])
    }

    /// Runs a command that must fail with a message naming every one of `needles`; returns its
    /// stderr.
    #[track_caller]
    pub fn fails_naming_all(&self, args: &[&str], needles: &[&str]) -> String {
        let err = self.fails(args);
        for n in needles {
            assert!(err.contains(n), "brdfwave {args:?}: no {n:?} in:\n{err}");
        }
        err
    }

    /// A fresh, empty directory `name` in the scratch folder.
    pub fn fresh_dir(&self, name: &str) -> PathBuf {
        let d = self.tmp(name);
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }
}

/// The binary, in the test's working directory and environment.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_brdfwave"))
}

/// The options `brdfwave COMMAND --help` lists under "Options:" (long and short, help itself
/// aside): clap's own list, for tests whose tables must name every option.
pub fn help_options(command: &str) -> Vec<String> {
    let out = bin().args([command, "--help"]).output().unwrap();
    let help = String::from_utf8(out.stdout).unwrap();
    help.lines()
        .skip_while(|l| *l != "Options:")
        .filter_map(|l| l.trim_start().split([' ', ',']).next())
        .filter(|w| w.starts_with('-') && *w != "-h" && *w != "--help")
        .map(str::to_string)
        .collect()
}

/// `brdf eval` of `material` on the directions file `dirs`, then `extra`.
pub fn eval_args<'a>(material: &'a str, dirs: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["brdf", "eval", "--material", material, "--dirs", dirs];
    a.extend_from_slice(extra);
    a
}

/// A quick render of the Cornell box on the CPU with the given extra arguments.
pub fn render_args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["render", "scenes/cornell-box.toml"];
    a.extend_from_slice(&super::QUICK_RENDER);
    a.extend_from_slice(extra);
    a
}

/// [`render_args`] with `spp` samples per pixel instead of [`super::QUICK_RENDER`]'s one.
pub fn render_args_spp<'a>(spp: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = render_args(extra);
    let at = a.iter().position(|&w| w == "--spp").unwrap() + 1;
    a[at] = spp;
    a
}

/// A path as the `&str` of a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}
