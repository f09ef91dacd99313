//! OBJ reader: any bytes must give a mesh or an error, never a panic, hang or huge allocation.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = rigfit_formats::obj::parse_obj(data);
});
