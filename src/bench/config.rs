//! The benchmark's configurations, their names and their parsing.

use crate::gpu::Integrator;
use crate::rng::Sampler;
use anyhow::{anyhow, bail, Result};

/// One configuration of the benchmark.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Config {
    /// The GPU renderer with this integrator and lavapipe thread count (None: the default).
    Gpu {
        integrator: Integrator,
        threads: Option<u32>,
        sampler: Sampler,
    },
    /// The CPU reference renderer (all cores, rayon).
    Cpu { sampler: Sampler },
    /// Mitsuba 3 with this variant (`scalar_rgb`, `llvm_ad_rgb`, `cuda_ad_rgb`) and sampler
    /// plugin (one of [`MITSUBA_SAMPLERS`]).
    Mitsuba { variant: String, sampler: String },
}

/// Mitsuba 3's sampler plugins that a Mitsuba configuration may name; `independent` is the
/// default (and is not written in the configuration's name).
pub const MITSUBA_SAMPLERS: [&str; 5] = [
    "independent",
    "stratified",
    "multijitter",
    "orthogonal",
    "ldsampler",
];

impl Config {
    pub fn name(&self) -> String {
        let ours = |base: String, s: &Sampler| match s {
            s if *s == Sampler::default() => base,
            s => format!("{base}-{s}"),
        };
        match self {
            Config::Gpu {
                integrator,
                threads,
                sampler,
            } => ours(
                match threads {
                    Some(t) => format!("{}-t{t}", integrator.name()),
                    None => integrator.name().to_string(),
                },
                sampler,
            ),
            Config::Cpu { sampler } => ours("cpu".into(), sampler),
            Config::Mitsuba { variant, sampler } => {
                let v = variant.trim_end_matches("_ad_rgb").trim_end_matches("_rgb");
                match sampler.as_str() {
                    "independent" => format!("mitsuba-{v}"),
                    s => format!("mitsuba-{v}-{s}"),
                }
            }
        }
    }

    /// The sampler this configuration uses, as its system names it.
    pub fn sampler_name(&self) -> String {
        match self {
            Config::Gpu { sampler, .. } | Config::Cpu { sampler } => sampler.name().into(),
            Config::Mitsuba { sampler, .. } => sampler.clone(),
        }
    }

    pub fn parse(name: &str) -> Result<Config> {
        if let Some(rest) = name.strip_prefix("mitsuba-") {
            let (v, sampler) = match rest.split_once('-') {
                Some((v, s)) => (v, s),
                None => (rest, "independent"),
            };
            if !MITSUBA_SAMPLERS.contains(&sampler) {
                bail!(
                    "configuration '{name}': unknown Mitsuba sampler '{sampler}' (use one of {})",
                    MITSUBA_SAMPLERS.join(", ")
                );
            }
            let variant = match v {
                "scalar" => "scalar_rgb",
                "llvm" => "llvm_ad_rgb",
                "cuda" => "cuda_ad_rgb",
                _ => bail!("configuration '{name}': unknown Mitsuba variant '{v}' (use scalar, llvm or cuda)"),
            };
            return Ok(Config::Mitsuba {
                variant: variant.into(),
                sampler: sampler.into(),
            });
        }
        // Ours: BASE[-tN][-SAMPLER].
        let (name, sampler) = match Sampler::ALL
            .iter()
            .find_map(|s| name.strip_suffix(&format!("-{s}")).map(|n| (n, *s)))
        {
            Some((n, s)) => (n, s),
            None => (name, Sampler::default()),
        };
        let gpu = |integrator, rest: &str| -> Result<Config> {
            let threads = match rest {
                "" => None,
                t => Some(
                    t.strip_prefix("-t")
                        .and_then(|n| n.parse::<u32>().ok())
                        .filter(|&n| (1..=256).contains(&n))
                        .ok_or_else(|| anyhow!("configuration '{name}': a thread count is written -tN, N from 1 to 256"))?,
                ),
            };
            Ok(Config::Gpu {
                integrator,
                threads,
                sampler,
            })
        };
        if name == "cpu" {
            Ok(Config::Cpu { sampler })
        } else if let Some(rest) = name.strip_prefix("wavefront") {
            gpu(Integrator::Wavefront, rest)
        } else if let Some(rest) = name.strip_prefix("megakernel") {
            gpu(Integrator::Megakernel, rest)
        } else {
            bail!(
                "unknown configuration '{name}': use wavefront, megakernel (each optionally -t1, -t2, …), cpu, each optionally -{} last; or mitsuba-scalar, mitsuba-llvm, mitsuba-cuda, each optionally -SAMPLER last ({})",
                Sampler::ALL.map(|s| s.name()).join(" or -"),
                MITSUBA_SAMPLERS.join(", ")
            )
        }
    }
}

/// The default configurations: everything that runs here (Mitsuba's are skipped with a note
/// when the module is missing).
pub const DEFAULT_CONFIGS: &str = "wavefront,wavefront-sobol,wavefront-independent,megakernel,cpu,cpu-independent,wavefront-t1,wavefront-t2,mitsuba-scalar,mitsuba-llvm,mitsuba-llvm-multijitter,mitsuba-llvm-ldsampler";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn config_names_round_trip() {
        for n in DEFAULT_CONFIGS.split(',').chain([
            "megakernel-t1",
            "mitsuba-cuda",
            "megakernel-t2-independent",
            "mitsuba-scalar-orthogonal",
        ]) {
            assert_eq!(Config::parse(n).unwrap().name(), n);
        }
        // The default sampler is not written in the name.
        assert_eq!(Config::parse("cpu-multijitter").unwrap().name(), "cpu");
        assert_eq!(Config::parse("cpu-sobol").unwrap().name(), "cpu-sobol");
        assert_eq!(
            Config::parse("wavefront-t1-independent").unwrap(),
            Config::Gpu {
                integrator: Integrator::Wavefront,
                threads: Some(1),
                sampler: Sampler::Independent
            }
        );
        assert_eq!(
            Config::parse("mitsuba-llvm").unwrap().sampler_name(),
            "independent"
        );
        assert!(Config::parse("wavefront-t0").is_err());
        assert!(Config::parse("pbrt").is_err());
        assert!(Config::parse("mitsuba-llvm-halton").is_err());
        assert!(Config::parse("mitsuba-vulkan").is_err());
        assert!(Config::parse("cpu-t2").is_err());
    }
}
