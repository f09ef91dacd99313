//! Strokes JSON reader: any bytes must give strokes or an error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rigfit_formats::strokes::parse_strokes(data);
});
