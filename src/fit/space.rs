//! The parameter space of a model's fit, derived from its registry row: which of the model
//! file's `PARAMS` are fitted, their bounds, and the map between the optimiser's unit cube and
//! parameter values. Nothing here is written per model.
//!
//! A parameter is fitted when all of these hold, and otherwise left out of the material (so
//! the model's default, or the default it derives, applies):
//! * it is a number or an RGB triple, not a choice (the fit keeps the model's default variant;
//!   fit another variant by naming it, `--models 'ward variant="duer2006"'`, see
//!   [`ModelSpec`]);
//! * its default is a plain value, not one the model derives (`alpha_y = alpha_x`: the fit stays
//!   isotropic, as MERL data is);
//! * it has a bounded range, from the declared `min`/`max` or, where the model checks its own
//!   range, from the documented range text (`[0, π/2]`, `(0, 1000]`);
//! * writing it at its default leaves the material unchanged (same GPU record): a parameter
//!   whose mere presence changes the model (Schlick's second layer `c2`) or that the model
//!   refuses in its default variant (Cook–Torrance's `eta` with the dielectric Fresnel term) is
//!   not fitted;
//! * moving it across its range changes f_r: an inert parameter (a rotation of an isotropic
//!   lobe) is not fitted.
//!
//! Coordinates: a scalar whose range spans two decades or more is searched on a log scale
//! (a closed lower bound of 0 becomes 10⁻³, an open one too); other scalars and RGB
//! coefficients linearly (a closed 0 must stay reachable: a zero diffuse term). An RGB
//! parameter is one grey coordinate in the first stage of the fit and three channels after
//! ([`super`]).

use crate::brdf::{inline::parse_inline_from, Brdf, Kind, ModelInfo, Param, MODELS};
use anyhow::{anyhow, bail, Result};
use glam::Vec3;
use std::sync::Arc;

/// The lower end of a log-scale coordinate whose declared lower bound is 0 or open.
const LOG_FLOOR: f32 = 1e-3;

/// One fitted parameter and its search interval.
#[derive(Clone, Debug)]
pub struct Bound {
    pub param: &'static Param,
    pub lo: f32,
    pub hi: f32,
    pub log: bool,
}

impl Bound {
    /// The value at unit coordinate `u` ∈ [0, 1].
    pub fn value(&self, u: f64) -> f32 {
        let u = u.clamp(0.0, 1.0) as f32;
        if self.log {
            (self.lo.ln() + u * (self.hi.ln() - self.lo.ln())).exp()
        } else {
            self.lo + u * (self.hi - self.lo)
        }
    }
    /// The unit coordinate of `v` (clamped into the interval).
    pub fn unit(&self, v: f32) -> f64 {
        let v = v.clamp(self.lo, self.hi);
        let u = if self.log {
            (v.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        };
        u as f64
    }
    fn is_rgb(&self) -> bool {
        matches!(self.param.kind, Kind::Rgb(_))
    }
}

/// A model to fit: its registry row and fixed fields (a variant, given on the command line).
#[derive(Clone)]
pub struct ModelSpec {
    pub model: &'static ModelInfo,
    /// Fields written into every candidate as given (`variant = "duer2006"`).
    pub fixed: String,
    /// The names of the fixed fields.
    fixed_keys: Vec<String>,
}

impl std::fmt::Debug for ModelSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ModelSpec({})", self.label())
    }
}

impl ModelSpec {
    /// Whether the model has parameters to fit: not a measured table (a file parameter).
    pub fn fittable(model: &ModelInfo) -> bool {
        !model.params.iter().any(|p| p.kind == Kind::File)
    }

    /// `name` or `name field = value, …` (fields are TOML, as in a scene file).
    pub fn parse(text: &str) -> Result<ModelSpec> {
        let text = text.trim();
        let (name, fixed) = match text.split_once(char::is_whitespace) {
            Some((n, rest)) => (n, rest.trim().to_string()),
            None => (text, String::new()),
        };
        let model = MODELS.iter().find(|m| m.name == name).ok_or_else(|| {
            let names: Vec<&str> = MODELS.iter().map(|m| m.name).collect();
            anyhow!(
                "--models: unknown model '{name}': expected one of {}",
                names.join(", ")
            )
        })?;
        if !Self::fittable(model) {
            bail!("--models: '{name}' is a measured table, not a model with parameters to fit");
        }
        let keys = toml::from_str::<toml::Table>(&format!("m = {{ {fixed} }}"))
            .ok()
            .and_then(|t| t.get("m").and_then(|m| m.as_table()).cloned())
            .ok_or_else(|| anyhow!("--models '{text}': the fields after the model's name are not TOML fields (name = value, …)"))?;
        let spec = ModelSpec {
            model,
            fixed,
            fixed_keys: keys.keys().cloned().collect(),
        };
        spec.material(&[])
            .map_err(|e| anyhow!("--models '{text}': {e}"))?;
        Ok(spec)
    }

    /// A label: the model's name with its fixed fields.
    pub fn label(&self) -> String {
        if self.fixed.is_empty() {
            self.model.name.to_string()
        } else {
            format!("{} ({})", self.model.name, self.fixed)
        }
    }

    /// The material text with these fields (name, TOML value) added.
    pub fn text(&self, fields: &[(&str, String)]) -> String {
        let mut s = format!("model = \"{}\"", self.model.name);
        if !self.fixed.is_empty() {
            s.push_str(", ");
            s.push_str(&self.fixed);
        }
        for (k, v) in fields {
            s.push_str(&format!(", {k} = {v}"));
        }
        s
    }

    /// The material with these fields added; warnings are dropped (candidates outside a
    /// model's recommended range are legal and may fit best).
    pub fn material(&self, fields: &[(&str, String)]) -> Result<Arc<dyn Brdf>> {
        let (m, _warnings) = parse_inline_from("fit candidate", &self.text(fields))?;
        Ok(m.brdf)
    }
}

/// The numeric ends of a documented range such as `[0, π/2]` or `(0, 1000]`: (lo, hi, lower
/// end open).
fn parse_range_text(t: &str) -> Option<(f32, f32, bool)> {
    let t = t.trim();
    let open = t.starts_with('(');
    let inner = t.get(1..t.len().checked_sub(1)?)?;
    let (a, b) = inner.split_once(',')?;
    let num = |s: &str| -> Option<f32> {
        let s = s.trim();
        match s {
            "π" => Some(std::f32::consts::PI),
            "π/2" => Some(std::f32::consts::FRAC_PI_2),
            _ => s.parse().ok(),
        }
    };
    Some((num(a)?, num(b)?, open))
}

/// The search interval of a parameter, or `None` when it has no bounded range.
fn bound_of(param: &'static Param) -> Option<Bound> {
    let (mut lo, hi, open) = match (
        param.min.is_finite() && param.max.is_finite(),
        param.range_text,
    ) {
        (_, Some(t)) => parse_range_text(t)?,
        (true, None) => (param.min, param.max, false),
        (false, None) => return None,
    };
    if !(lo.is_finite() && hi.is_finite() && hi > lo) {
        return None;
    }
    let scalar = matches!(param.kind, Kind::Scalar(_));
    if open || (scalar && lo <= 0.0) {
        lo = lo.max(LOG_FLOOR);
    }
    let log = lo > 0.0 && hi / lo >= 100.0 && (scalar || open);
    Some(Bound { param, lo, hi, log })
}

/// A parameter value as TOML.
pub fn toml_value(kind: &Kind, v: Vec3) -> String {
    match kind {
        Kind::Rgb(_) => format!("[{}, {}, {}]", v.x, v.y, v.z),
        _ => format!("{}", v.x),
    }
}

/// The default value of a number or RGB parameter.
fn default_of(param: &Param) -> Option<Vec3> {
    match param.kind {
        Kind::Rgb(d) => Some(Vec3::from_array(d)),
        Kind::Scalar(d) => Some(Vec3::splat(d)),
        Kind::Choice(..) | Kind::File => None,
    }
}

/// Whether two evaluations agree within rounding (a rotation of an isotropic lobe changes the
/// last bits only).
fn same_values(a: &[Vec3], b: &[Vec3]) -> bool {
    a.iter()
        .zip(b)
        .all(|(x, y)| ((*x - *y).abs() - 1e-4 * x.abs().max(y.abs())).max_element() <= 1e-12)
}

/// The fitted parameters of a model, in `PARAMS` order.
#[derive(Clone, Debug)]
pub struct Space {
    pub spec: ModelSpec,
    pub bounds: Vec<Bound>,
}

impl Space {
    /// The parameters of `spec` that are fitted (module documentation); `probes` are direction
    /// pairs for the inertness test.
    pub fn new(spec: ModelSpec, probes: &[(Vec3, Vec3)]) -> Result<Space> {
        let base = spec.material(&[])?;
        let eval_all =
            |b: &dyn Brdf| -> Vec<Vec3> { probes.iter().map(|&(wi, wo)| b.eval(wi, wo)).collect() };
        let mut bounds = Vec::new();
        for param in spec.model.params {
            let Some(default) = default_of(param) else {
                continue;
            };
            if param.default_text.is_some() || spec.fixed_keys.iter().any(|k| k == param.name) {
                continue;
            }
            let Some(bound) = bound_of(param) else {
                continue;
            };
            let with = |v: Vec3| spec.material(&[(param.name, toml_value(&param.kind, v))]);
            match with(default) {
                Ok(m) if m.pack() == base.pack() => {}
                _ => continue,
            }
            let ends: Vec<Vec<Vec3>> = [0.1, 0.9]
                .iter()
                .filter_map(|&u| with(Vec3::splat(bound.value(u))).ok())
                .map(|m| eval_all(m.as_ref()))
                .collect();
            if ends.len() == 2 && same_values(&ends[0], &ends[1]) {
                continue;
            }
            bounds.push(bound);
        }
        if bounds.is_empty() {
            bail!("{}: no parameter of the model can be fitted", spec.label());
        }
        Ok(Space { spec, bounds })
    }

    /// The defaults of the fitted parameters, clamped into their intervals.
    pub fn defaults(&self) -> Vec<Vec3> {
        self.bounds
            .iter()
            .map(|b| {
                let d = default_of(b.param).expect("fitted parameters have defaults");
                d.clamp(Vec3::splat(b.lo), Vec3::splat(b.hi))
            })
            .collect()
    }

    /// Indices of the RGB parameters among `bounds`.
    pub fn rgb_indices(&self) -> Vec<usize> {
        (0..self.bounds.len())
            .filter(|&i| self.bounds[i].is_rgb())
            .collect()
    }

    /// The material with these values of the fitted parameters.
    pub fn material(&self, values: &[Vec3]) -> Result<Arc<dyn Brdf>> {
        let fields: Vec<(&str, String)> = self
            .bounds
            .iter()
            .zip(values)
            .map(|(b, v)| (b.param.name, toml_value(&b.param.kind, *v)))
            .collect();
        self.spec.material(&fields)
    }

    /// The material text with these values (for `materials.toml`).
    pub fn fields(&self, values: &[Vec3]) -> Vec<(&'static str, String)> {
        self.bounds
            .iter()
            .zip(values)
            .map(|(b, v)| (b.param.name, toml_value(&b.param.kind, *v)))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn probes() -> Vec<(Vec3, Vec3)> {
        let d = |t: f32, p: f32| crate::brdf::validate::dir_from_theta_deg(t, p);
        vec![
            (d(20.0, 0.0), d(30.0, 180.0)),
            (d(50.0, 40.0), d(10.0, 250.0)),
        ]
    }

    fn names(model: &str) -> Vec<&'static str> {
        let s = Space::new(ModelSpec::parse(model).unwrap(), &probes()).unwrap();
        s.bounds.iter().map(|b| b.param.name).collect()
    }

    #[test]
    fn fitted_parameters_follow_from_the_declarations() {
        assert_eq!(names("lambert"), ["albedo"]);
        assert_eq!(names("ward"), ["kd", "ks", "alpha_x"]);
        assert_eq!(names("oren_nayar"), ["albedo", "sigma"]);
        assert_eq!(names("cook_torrance"), ["kd", "ks", "roughness", "ior"]);
        assert_eq!(
            names(r#"cook_torrance fresnel = "schlick""#),
            ["kd", "ks", "roughness", "f0"]
        );
        // The rotation of an isotropic lobe is inert; the second layer is not the default.
        assert!(!names("schlick").contains(&"rotation"));
        assert!(!names("schlick").contains(&"c2"));
    }

    #[test]
    fn range_texts_and_log_scales() {
        assert_eq!(
            parse_range_text("[0, π/2]"),
            Some((0.0, std::f32::consts::FRAC_PI_2, false))
        );
        assert_eq!(parse_range_text("(0, 1000]"), Some((0.0, 1000.0, true)));
        assert_eq!(parse_range_text("up to 3"), None);
        let s = Space::new(ModelSpec::parse("ward").unwrap(), &probes()).unwrap();
        let alpha = &s.bounds[2];
        assert!(alpha.log && alpha.lo == 0.001 && alpha.hi == 1.0);
        assert!((alpha.value(alpha.unit(0.2)) - 0.2).abs() < 1e-6);
        assert!(!s.bounds[0].log && s.bounds[0].lo == 0.0);
        assert!(ModelSpec::parse("warp")
            .unwrap_err()
            .to_string()
            .contains("unknown model"));
        assert!(ModelSpec::parse("ward variant = 3").is_err());
    }
}
