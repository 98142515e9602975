//! The text outputs of `brdf fit`: `fit.md`, `fit.csv`, `materials.toml` and the lineup scene.

use super::{FitOptions, ModelFit};
use std::fmt::Write as _;

/// The fits in rank order (lowest error first), as indices into `fits`.
pub fn ranking(fits: &[ModelFit]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..fits.len()).collect();
    order.sort_by(|&a, &b| fits[a].error.total_cmp(&fits[b].error));
    order
}

/// Scene-file material names, `fit_<model>_<options>` from the variant
/// ([`super::space::ModelSpec::slug`]), with `_2`, `_3`, … for a variant fitted twice.
pub fn material_names(fits: &[ModelFit]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for f in fits {
        let base = format!("fit_{}", f.space.spec.slug());
        let mut name = base.clone();
        let mut k = 2;
        while names.contains(&name) {
            name = format!("{base}_{k}");
            k += 1;
        }
        names.push(name);
    }
    names
}

/// The best fit of each model (the lowest error among its variants), in rank order.
pub fn best_per_model(fits: &[ModelFit]) -> Vec<usize> {
    let mut seen: Vec<&str> = Vec::new();
    ranking(fits)
        .into_iter()
        .filter(|&i| {
            let name = fits[i].space.spec.model.name;
            let first = !seen.contains(&name);
            seen.push(name);
            first
        })
        .collect()
}

/// What the run compared, for the heads of the files.
pub struct Context<'a> {
    pub measured: &'a str,
    /// The measured file as the lineup's `measured` material names it (an absolute path, so
    /// that the scene renders from any directory).
    pub measured_file: &'a str,
    pub samples: usize,
    pub missing: usize,
    pub options: &'a FitOptions,
}

fn relative(f: &ModelFit, best: f64) -> f64 {
    if best > 0.0 {
        f.error / best
    } else if f.error > 0.0 {
        f64::INFINITY
    } else {
        1.0
    }
}

/// `fit.md`: the summary table in rank order, then a table of parameters per model.
pub fn markdown(fits: &[ModelFit], ctx: &Context) -> String {
    let order = ranking(fits);
    let best = order.first().map(|&i| fits[i].error).unwrap_or(0.0);
    let mut s = String::new();
    let _ = writeln!(s, "# brdf fit: {}\n", ctx.measured);
    let _ = writeln!(
        s,
        "Error: the weighted RMS of ∛(f_fit cosθi) − ∛(f_measured cosθi) over {} MERL cells \
         with θi, θo ≤ {}° ({} missing values in the file); lower is better. \"× best\" is the \
         error relative to the best fit. Times are wall-clock, the models fitted in parallel.\n",
        ctx.samples, ctx.options.max_theta_deg, ctx.missing
    );
    let bests: Vec<String> = best_per_model(fits)
        .iter()
        .map(|&i| {
            let rank = order.iter().position(|&j| j == i).unwrap_or(0) + 1;
            format!("`{}` ({rank})", fits[i].space.spec.label())
        })
        .collect();
    let _ = writeln!(
        s,
        "Each variant (`model:option…`, one option of each choice parameter) is a fit of its own. \
         The best variant of each model, with its rank: {}.\n",
        bests.join(", ")
    );
    s.push_str("| rank | model | error | × best | evaluations | time (s) |\n");
    s.push_str("|---|---|---|---|---|---|\n");
    for (rank, &i) in order.iter().enumerate() {
        let f = &fits[i];
        let _ = writeln!(
            s,
            "| {} | {} | {:.4e} | {:.2} | {} | {:.2} |",
            rank + 1,
            f.space.spec.label(),
            f.error,
            relative(f, best),
            f.evals,
            f.seconds
        );
    }
    for &i in &order {
        let f = &fits[i];
        let _ = writeln!(s, "\n## {}\n", f.space.spec.label());
        s.push_str("| parameter | value | searched in |\n|---|---|---|\n");
        for ((name, value), b) in f.space.fields(&f.values).iter().zip(&f.space.bounds) {
            let scale = b.scale_text();
            let _ = writeln!(s, "| `{name}` | `{value}` | [{}, {}]{scale} |", b.lo, b.hi);
        }
        let fixed = f.space.spec.fixed_fields();
        if !fixed.is_empty() {
            let list: Vec<String> = fixed.iter().map(|(k, v)| format!("`{k} = {v}`")).collect();
            let _ = writeln!(s, "\nFixed: {}.", list.join(", "));
        }
    }
    s
}

/// A CSV field, quoted when it holds a comma or a quote.
fn csv_field(v: &str) -> String {
    if v.contains([',', '"', '\n']) {
        format!("\"{}\"", v.replace('"', "\"\""))
    } else {
        v.to_string()
    }
}

/// `fit.csv`: one row per model in rank order; `material` is the fitted material's TOML.
pub fn csv(fits: &[ModelFit]) -> String {
    let order = ranking(fits);
    let best = order.first().map(|&i| fits[i].error).unwrap_or(0.0);
    let mut s = String::from("rank,model,error,relative_to_best,evaluations,seconds,material\n");
    for (rank, &i) in order.iter().enumerate() {
        let f = &fits[i];
        let _ = writeln!(
            s,
            "{},{},{:e},{},{},{:.3},{}",
            rank + 1,
            csv_field(&f.space.spec.label()),
            f.error,
            relative(f, best),
            f.evals,
            f.seconds,
            csv_field(&f.material_text())
        );
    }
    s
}

/// One `[materials.NAME]` table per fit of `which`, in that order.
fn material_tables(fits: &[ModelFit], names: &[String], which: &[usize]) -> String {
    let mut s = String::new();
    for &i in which {
        let f = &fits[i];
        let _ = writeln!(s, "# {}: error {:.4e}", f.space.spec.label(), f.error);
        let _ = writeln!(s, "[materials.{}]", names[i]);
        let _ = writeln!(s, "model = \"{}\"", f.space.spec.model.name);
        // The variant's choices and the fixed fields, one per line.
        for (k, v) in f.space.spec.fixed_fields() {
            let _ = writeln!(s, "{k} = {v}");
        }
        for (name, value) in f.space.fields(&f.values) {
            let _ = writeln!(s, "{name} = {value}");
        }
        s.push('\n');
    }
    s
}

/// `materials.toml`: the fitted materials, ready to paste into a scene.
pub fn materials_toml(fits: &[ModelFit], ctx: &Context) -> String {
    format!(
        "# The survey's models fitted to {} by `brdfwave brdf fit`, best first.\n# Paste a \
         table into a scene file and name it in a shape's `material`.\n\n{}",
        ctx.measured,
        material_tables(fits, &material_names(fits), &ranking(fits))
    )
}

/// `lineup.toml`: the measured material itself on the left, then one sphere per fitted model
/// (its best variant) in rank order, best first, under the light and environment of
/// `scenes/lineup.toml`.
pub fn lineup_scene(fits: &[ModelFit], ctx: &Context) -> String {
    let names = material_names(fits);
    let order = best_per_model(fits);
    let n = order.len() + 1;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# The survey's models fitted to {} by `brdfwave brdf fit`, one sphere each: the measured \
         material\n# itself (model \"measured\") on the left, then each model's best variant, \
         best first:\n# {}.\n",
        ctx.measured,
        order
            .iter()
            .map(|&i| fits[i].space.spec.label())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        s,
        "[camera]\nposition = [0.0, 2.2, -{:.1}]\ntarget = [0.0, 0.45, 0.0]\nup = [0.0, 1.0, 0.0]\n\
         fov_y = 22.0\n\n[film]\nwidth = {}\nheight = 200\n\n[integrator]\nspp = 32\nmax_depth = 6\n\
         seed = 0\n\n[environment]\nradiance = [0.08, 0.09, 0.1]\n\n[materials.floor]\n\
         model = \"lambert\"\nalbedo = [0.4, 0.4, 0.4]\n\n[materials.light]\nmodel = \"lambert\"\n\
         albedo = [0.0, 0.0, 0.0]\n",
        (9.0 * n as f32 / 8.0).max(4.0),
        (80 * n as u32).clamp(240, 1280)
    );
    let _ = writeln!(
        s,
        "[materials.measured]\nmodel = \"measured\"\nfile = {}\n",
        toml::Value::String(ctx.measured_file.to_string())
    );
    s.push_str(&material_tables(fits, &names, &order));
    s.push_str(
        "[[shapes]]\nname = \"floor\"\nmaterial = \"floor\"\nquads = [[[-20.0, 0.0, -20.0], \
         [-20.0, 0.0, 20.0], [20.0, 0.0, 20.0], [20.0, 0.0, -20.0]]]\n\n[[shapes]]\n\
         name = \"light\"\nmaterial = \"light\"\nemission = [6.0, 6.0, 6.0]\nquads = [[[-5.0, \
         6.0, -4.0], [5.0, 6.0, -4.0], [5.0, 6.0, 1.0], [-5.0, 6.0, 1.0]]]\n",
    );
    let spheres = std::iter::once("measured").chain(order.iter().map(|&i| names[i].as_str()));
    for (k, name) in spheres.enumerate() {
        // Image x runs to the camera's right, which is world −x here: the first sphere at +x.
        let x = (n as f32 - 1.0) / 2.0 - k as f32;
        let _ = writeln!(
            s,
            "\n[[shapes]]\nname = \"{name}\"\nmaterial = \"{name}\"\nsphere = {{ center = [{x:.1}, \
             0.45, 0.0], radius = 0.45 }}"
        );
    }
    s
}
