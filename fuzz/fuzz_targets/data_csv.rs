//! Fuzz target: arbitrary bytes as a data CSV (`t,z1,…,zm[,u1,…,up]`), read row by row by
//! the streaming reader. Every input must give `Ok` or a clean error, never a panic.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use scenarios::userdata::data::parse_data;

fuzz_target!(|data: &[u8]| {
    let _ = parse_data(Path::new("z.csv"), data);
});
