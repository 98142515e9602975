//! The commands of `brdfwave`, one module each with its arguments and its `run`, and what
//! they share: the option parsers and the backend choice.

pub mod bench;
pub mod brdf;
pub mod convert;
pub mod devices;
pub mod diff;
pub mod docs;
pub mod fit;
pub mod merge;
pub mod rays;
pub mod render;
pub mod stress;
mod summary;

use clap::ValueEnum;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    Gpu,
    Cpu,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegratorArg {
    Auto,
    Wavefront,
    Megakernel,
}

impl IntegratorArg {
    pub fn gpu(self) -> brdfwave::gpu::Integrator {
        match self {
            IntegratorArg::Auto => brdfwave::gpu::Integrator::Auto,
            IntegratorArg::Wavefront => brdfwave::gpu::Integrator::Wavefront,
            IntegratorArg::Megakernel => brdfwave::gpu::Integrator::Megakernel,
        }
    }
}

pub fn parse_sampler(s: &str) -> std::result::Result<brdfwave::rng::Sampler, String> {
    brdfwave::rng::Sampler::parse(s).ok_or_else(|| {
        format!(
            "unknown sampler '{s}': expected one of {}",
            brdfwave::rng::Sampler::names()
        )
    })
}

/// `NAME=VALUE` of `-D` (a Mitsuba scene parameter).
pub fn parse_define(s: &str) -> std::result::Result<(String, String), String> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("'{s}' is not NAME=VALUE"))?;
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(format!(
            "'{name}' is not a parameter name (letters, digits and underscores)"
        ));
    }
    Ok((name.to_string(), value.to_string()))
}

pub fn parse_res(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not WxH (e.g. 256x256)"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in '{s}'"))?;
    let max = brdfwave::conventions::MAX_FILM_SIZE;
    if w == 0 || h == 0 || w > max || h > max {
        return Err(format!(
            "resolution '{s}' must be between 1x1 and {max}x{max}"
        ));
    }
    Ok((w, h))
}

pub fn parse_device(s: &str) -> std::result::Result<String, String> {
    if s.trim().is_empty() {
        return Err("the device name is empty; `brdfwave devices` lists the names".to_string());
    }
    Ok(s.to_string())
}

/// Warns about options given with the CPU backend, which ignores them.
pub fn warn_gpu_only(options: &[(&str, bool)]) {
    for (name, given) in options {
        if *given {
            eprintln!("warning: {name} applies to the GPU backend only; ignored");
        }
    }
}
