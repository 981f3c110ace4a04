//! Value parsers for numeric flags: each checks its range where the flag is parsed, so a
//! command never starts with a value it cannot use (and clap names the flag in the error).

/// The largest image side any command renders or writes.
pub const MAX_SIDE: u32 = 16_384;

fn number<T: std::str::FromStr>(text: &str) -> Result<T, String>
where
    T::Err: std::fmt::Display,
{
    text.trim().parse::<T>().map_err(|e| format!("'{text}' is not a number: {e}"))
}

/// An image side in pixels, 1..=[`MAX_SIDE`].
pub fn image_side(text: &str) -> Result<u32, String> {
    let v: u32 = number(text)?;
    if (1..=MAX_SIDE).contains(&v) { Ok(v) } else { Err(format!("{v} must be in 1..={MAX_SIDE} pixels")) }
}

/// [`image_side`] as a `usize`.
pub fn image_side_usize(text: &str) -> Result<usize, String> {
    image_side(text).map(|v| v as usize)
}

/// A count of at least one.
pub fn at_least_one(text: &str) -> Result<usize, String> {
    let v: usize = number(text)?;
    if v >= 1 { Ok(v) } else { Err("must be at least 1".into()) }
}

/// Rays per pixel over a lens, 1..=4096.
pub fn lens_rays(text: &str) -> Result<usize, String> {
    let v: usize = number(text)?;
    if (1..=4096).contains(&v) { Ok(v) } else { Err(format!("{v} must be in 1..=4096")) }
}

/// Frames of a camera path, 1..=100 000.
pub fn frames(text: &str) -> Result<usize, String> {
    let v: usize = number(text)?;
    if (1..=100_000).contains(&v) { Ok(v) } else { Err(format!("{v} must be in 1..=100000")) }
}

/// A finite number.
pub fn finite(text: &str) -> Result<f32, String> {
    let v: f32 = number(text)?;
    if v.is_finite() { Ok(v) } else { Err(format!("{v} is not a finite number")) }
}

/// A positive finite number.
pub fn positive(text: &str) -> Result<f32, String> {
    let v = finite(text)?;
    if v > 0.0 { Ok(v) } else { Err(format!("{v} must be positive")) }
}

/// Zero or a positive finite number.
pub fn non_negative(text: &str) -> Result<f32, String> {
    let v = finite(text)?;
    if v >= 0.0 { Ok(v) } else { Err(format!("{v} must be zero or positive")) }
}

/// An elevation in degrees, in [-90, 90].
pub fn elevation(text: &str) -> Result<f32, String> {
    let v = finite(text)?;
    if (-90.0..=90.0).contains(&v) { Ok(v) } else { Err(format!("{v} must be in [-90, 90] degrees")) }
}

/// An exposure change in stops, in [-64, 64] (2^64 is past any radiance an f32 image holds).
pub fn stops(text: &str) -> Result<f32, String> {
    let v = finite(text)?;
    if (-64.0..=64.0).contains(&v) { Ok(v) } else { Err(format!("{v} must be in [-64, 64] stops")) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_refuse_what_they_must() {
        assert_eq!(image_side("512"), Ok(512));
        for bad in ["0", "16385", "-1", "1e9", "x"] {
            assert!(image_side(bad).is_err(), "{bad}");
        }
        assert!(lens_rays("0").is_err() && lens_rays("4097").is_err() && lens_rays("32") == Ok(32));
        assert!(elevation("NaN").is_err() && elevation("91").is_err() && elevation("-90") == Ok(-90.0));
        assert!(stops("1000").is_err() && stops("inf").is_err() && stops("-2.5") == Ok(-2.5));
        assert!(positive("0").is_err() && non_negative("-1e-9").is_err() && non_negative("0") == Ok(0.0));
        assert!(at_least_one("0").is_err() && at_least_one("3") == Ok(3));
    }
}
