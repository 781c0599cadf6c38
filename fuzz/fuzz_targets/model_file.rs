//! Fuzz target: arbitrary bytes as a discrete or continuous model file, JSON or TOML (the
//! first byte picks which). Every input must give `Ok` or a clean error, never a panic.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use scenarios::userdata::model_file::{parse_continuous, parse_discrete};

fuzz_target!(|data: &[u8]| {
    let Some((&selector, rest)) = data.split_first() else {
        return;
    };
    let Ok(text) = std::str::from_utf8(rest) else {
        return;
    };
    let path = Path::new(if selector & 1 == 0 {
        "m.json"
    } else {
        "m.toml"
    });
    if selector & 2 == 0 {
        let _ = parse_discrete(path, text);
    } else {
        let _ = parse_continuous(path, text);
    }
});
