//! Shared by the GPU benches: command-line values and medians.

/// The value after `name` on the command line, or `default`.
pub fn arg<T: std::str::FromStr>(name: &str, default: T) -> T {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// `--device SEL`, if given.
pub fn device_selector() -> Option<String> {
    std::env::args().skip_while(|a| a != "--device").nth(1)
}

#[allow(dead_code)] // not every bench takes medians
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
