//! Options an example sweeps, read from the environment: `NAME=value` overrides a default.
// Each example that includes this file uses some of it.
#![allow(dead_code)]

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

/// `name`'s value as a count, or `default` when it is not set or does not parse (a
/// fractional value is truncated).
pub fn count(name: &str, default: usize) -> usize {
    number(name).map_or(default, |v| v as usize)
}

/// `name`'s comma-separated names (the objects or rigs an example runs on), when it is set.
pub fn names(name: &str) -> Option<Vec<String>> {
    std::env::var(name)
        .ok()
        .map(|s| s.split(',').map(str::to_string).collect())
}
