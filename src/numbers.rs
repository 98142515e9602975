//! Numbers a user wrote, turned into the single-precision values the renderers use: one check
//! that every reader shares (TOML and XML scenes, OBJ, MTL and PLY files, measured tables), so
//! that a number that is finite as written but beyond single precision (`1e39`) is refused as
//! out of range, naming the number as it was written, instead of becoming `inf` and being
//! reported (or rendered) as that.

use crate::brdf::params::fmt_num;

/// The largest magnitude of a finite f32, as messages give it.
pub const F32_RANGE: &str = "|x| <= 3.4e38";

/// `x` as an f32, or why not: `NaN is not a finite number`, `1e39 is out of the single-precision
/// range (|x| <= 3.4e38)`. `shown` is how the number is written in messages (the user's text
/// when there is one).
pub fn f32_from(x: f64, shown: &str) -> Result<f32, String> {
    if !x.is_finite() {
        return Err(format!("{shown} is not a finite number"));
    }
    if x.abs() > f32::MAX as f64 {
        return Err(format!(
            "{shown} is out of the single-precision range ({F32_RANGE})"
        ));
    }
    Ok(x as f32)
}

/// [`f32_from`] for a computed value, shown as [`fmt_num`] writes it.
pub fn f32_of(x: f64) -> Result<f32, String> {
    f32_from(x, &fmt_num(x))
}

/// A number written as text (`1.5`, `-2e-3`) as an f32: the nearest f32 to the decimal (Rust's
/// correctly rounded parse), refused with the text quoted when it is not a number, not finite
/// or beyond single precision.
pub fn parse_f32(text: &str) -> Result<f32, String> {
    let t = text.trim();
    let shown = crate::errors::excerpt(t);
    let x: f64 = t
        .parse()
        .map_err(|_| format!("'{shown}' is not a number"))?;
    f32_from(x, &format!("'{shown}'"))?;
    // The f32 nearest the decimal itself (rounding through f64 could differ by one ulp).
    Ok(t.parse::<f32>().unwrap_or(x as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_beyond_single_precision_are_named_as_written() {
        assert_eq!(parse_f32(" 1.5 "), Ok(1.5));
        assert_eq!(parse_f32("3.4e38"), Ok(3.4e38));
        let e = parse_f32("1e39").unwrap_err();
        assert!(
            e.contains("'1e39'") && e.contains("out of the single-precision range"),
            "{e}"
        );
        assert!(!e.contains("inf"), "{e}");
        assert!(parse_f32("-5e41").unwrap_err().contains("'-5e41'"));
        assert!(parse_f32("nan")
            .unwrap_err()
            .contains("not a finite number"));
        assert!(parse_f32("inf")
            .unwrap_err()
            .contains("not a finite number"));
        assert!(parse_f32("1,5").unwrap_err().contains("is not a number"));
        assert!(f32_of(5e41).unwrap_err().starts_with("5e41 is out of"));
        assert_eq!(f32_of(-2.0), Ok(-2.0));
        assert!(parse_f32(&"9".repeat(100_000)).unwrap_err().len() < 300);
    }
}
