//! What benchmarks read off the processes they start: CPU time from `/proc`, and quantiles.

/// Clock ticks per second of `/proc/<pid>/stat` times (USER_HZ on Linux).
pub const USER_HZ: f64 = 100.0;

/// utime + stime of `pid`, in clock ticks (0 once the process is gone).
pub fn cpu_ticks(pid: u32) -> u64 {
    let s = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // Fields after the command name (which may hold spaces) start after the last ')'.
    let rest = s.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let get = |i: usize| f.get(i).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
    // utime and stime are fields 14 and 15 of stat; here 0-based after ')' : 11 and 12.
    get(11) + get(12)
}

/// utime + stime of `pid`, in seconds.
pub fn cpu_s(pid: u32) -> f64 {
    cpu_ticks(pid) as f64 / USER_HZ
}

/// The `q` quantile of `v` (nearest rank; sorts `v`); NaN when empty.
pub fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(((v.len().saturating_sub(1)) as f64 * q).round() as usize).copied().unwrap_or(f64::NAN)
}
