//! Verdicts on a [`DiffReport`]: thresholds `METRIC=VALUE` (`brdfwave diff --max`), each
//! failing when the metric is over its value.
//!
//! The metrics a threshold can name are [`Metric::ALL`]: the ones of [`DiffReport`] and `over`,
//! the fraction of pixels that differ by more than a tolerance in any channel
//! ([`super::fraction_within`]'s rule |t − r| <= rel · max(|t|, |r|) + abs; a non-finite value
//! never agrees).

use std::fmt;

use super::DiffReport;

/// A metric a threshold can bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    Rmse,
    Mse,
    Relmse,
    Flip,
    MaxAbs,
    /// Fraction of pixels, in [0, 1], over the tolerance.
    Over,
}

impl Metric {
    pub const ALL: [Metric; 6] = [
        Metric::Rmse,
        Metric::Mse,
        Metric::Relmse,
        Metric::Flip,
        Metric::MaxAbs,
        Metric::Over,
    ];

    /// The name on the command line and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Metric::Rmse => "rmse",
            Metric::Mse => "mse",
            Metric::Relmse => "relmse",
            Metric::Flip => "flip",
            Metric::MaxAbs => "max_abs",
            Metric::Over => "over",
        }
    }

    /// The metric named `s` (case-insensitive; `max-abs` is `max_abs`).
    pub fn parse(s: &str) -> Option<Metric> {
        let s = s.trim().to_ascii_lowercase().replace('-', "_");
        Metric::ALL.into_iter().find(|m| m.name() == s)
    }

    /// The metric's value in `report`; `over` is the given fraction of pixels over the
    /// tolerance.
    pub fn value(self, report: &DiffReport, over: f64) -> f64 {
        match self {
            Metric::Rmse => report.rmse,
            Metric::Mse => report.mse,
            Metric::Relmse => report.relmse,
            Metric::Flip => report.flip_mean,
            Metric::MaxAbs => report.max_abs,
            Metric::Over => over,
        }
    }
}

/// Why a threshold was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ThresholdError {
    #[error("'{0}' is not METRIC=VALUE (e.g. relmse=1e-3)")]
    Syntax(String),
    #[error("unknown metric '{name}' in '{text}': expected one of {}", names())]
    UnknownMetric { name: String, text: String },
    #[error("bad value '{value}' in '{text}': {reason}")]
    BadValue {
        value: String,
        text: String,
        reason: &'static str,
    },
}

fn names() -> String {
    Metric::ALL.map(Metric::name).join(", ")
}

/// `METRIC <= max`, the pass condition of one `--max METRIC=VALUE`.
#[derive(Clone, Debug, PartialEq)]
pub struct Threshold {
    pub metric: Metric,
    pub max: f64,
    /// The value as the user wrote it, for the messages.
    pub text: String,
}

impl Threshold {
    /// Parses `METRIC=VALUE`: VALUE a finite number >= 0 (at most 1 for `over` and `flip`,
    /// which are fractions).
    pub fn parse(s: &str) -> Result<Threshold, ThresholdError> {
        let (name, value) = s
            .split_once('=')
            .ok_or_else(|| ThresholdError::Syntax(s.to_string()))?;
        let metric = Metric::parse(name).ok_or_else(|| ThresholdError::UnknownMetric {
            name: name.trim().to_string(),
            text: s.to_string(),
        })?;
        let bad = |reason| ThresholdError::BadValue {
            value: value.trim().to_string(),
            text: s.to_string(),
            reason,
        };
        let max: f64 = value.trim().parse().map_err(|_| bad("not a number"))?;
        if !(max.is_finite() && max >= 0.0) {
            return Err(bad("must be finite and >= 0"));
        }
        if matches!(metric, Metric::Over | Metric::Flip) && max > 1.0 {
            return Err(bad("this metric is a fraction: at most 1"));
        }
        Ok(Threshold {
            metric,
            max,
            text: value.trim().to_string(),
        })
    }

    /// The verdict of this threshold on a metric's value (a NaN value fails).
    pub fn judge(&self, value: f64) -> Verdict {
        Verdict {
            metric: self.metric,
            value,
            max: self.max,
            max_text: self.text.clone(),
            pass: value <= self.max,
        }
    }
}

/// The outcome of one threshold.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Verdict {
    #[serde(serialize_with = "metric_name")]
    pub metric: Metric,
    pub value: f64,
    pub max: f64,
    #[serde(skip)]
    pub max_text: String,
    pub pass: bool,
}

fn metric_name<S: serde::Serializer>(m: &Metric, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(m.name())
}

/// `FAIL relmse 2.300e-3 > 1e-3` or `PASS relmse 1.200e-4 <= 1e-3`.
impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (word, op) = if self.pass {
            ("PASS", "<=")
        } else {
            ("FAIL", ">")
        };
        write!(
            f,
            "{word} {} {:.3e} {op} {}",
            self.metric.name(),
            self.value,
            self.max_text
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_metric_and_refuses_bad_thresholds() {
        for m in Metric::ALL {
            let t = Threshold::parse(&format!("{}=0.5", m.name())).unwrap();
            assert_eq!((t.metric, t.max), (m, 0.5));
        }
        assert_eq!(
            Threshold::parse("MAX-ABS = 2").unwrap().metric,
            Metric::MaxAbs
        );
        assert!(matches!(
            Threshold::parse("relmse"),
            Err(ThresholdError::Syntax(_))
        ));
        let e = Threshold::parse("psnr=30").unwrap_err().to_string();
        assert!(
            e.contains("unknown metric 'psnr'") && e.contains("relmse"),
            "{e}"
        );
        for bad in [
            "rmse=abc", "rmse=-1", "rmse=inf", "rmse=NaN", "over=1.5", "flip=2",
        ] {
            assert!(
                matches!(Threshold::parse(bad), Err(ThresholdError::BadValue { .. })),
                "{bad}"
            );
        }
    }

    #[test]
    fn verdicts_compare_and_read_as_one_line() {
        let t = Threshold::parse("relmse=1e-3").unwrap();
        let fail = t.judge(2.3e-3);
        assert!(!fail.pass);
        assert_eq!(fail.to_string(), "FAIL relmse 2.300e-3 > 1e-3");
        assert!(t.judge(1e-3).pass);
        assert_eq!(t.judge(1.2e-4).to_string(), "PASS relmse 1.200e-4 <= 1e-3");
        assert!(!t.judge(f64::NAN).pass);
    }
}
