//! Options an example sweeps, read from the environment: `NAME=value` overrides a default.

/// `name`'s value as a number, when it is set and parses.
pub fn number(name: &str) -> Option<f64> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

/// Sets `field` from `name` when it is set.
pub fn set(name: &str, field: &mut f64) {
    if let Some(v) = number(name) {
        *field = v;
    }
}

/// Sets the count `field` from `name` when it is set (a fractional value is truncated).
pub fn set_count(name: &str, field: &mut usize) {
    if let Some(v) = number(name) {
        *field = v as usize;
    }
}
