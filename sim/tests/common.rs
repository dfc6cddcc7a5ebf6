//! The harness every simulation test shares: many seeds on every core, or one seed replayed with
//! its trace.

use mrmm_sim::{run, run_many, Config};

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

/// Runs `MRMM_SIM_SEEDS` seeds (default `default`) from `MRMM_SIM_FIRST` (default 0), or replays
/// `MRMM_SIM_SEED` with its trace; panics with the failing seed and how to replay it.
pub fn seeds(what: &str, default: u64, config: fn(u64) -> Config) {
    if let Some(seed) = env_u64("MRMM_SIM_SEED") {
        // The machines' own log lines too, when asked for (RUST_LOG=info).
        if std::env::var_os("RUST_LOG").is_some() {
            let _ = tracing_subscriber::fmt().with_env_filter(tracing_subscriber::EnvFilter::from_default_env()).with_ansi(false).without_time().try_init();
        }
        let cfg = config(seed);
        println!("{what} seed {seed}: {cfg:?}");
        match run(cfg, true) {
            Ok(r) => {
                for line in &r.trace {
                    println!("{line}");
                }
                println!("ok: {r:?}");
            }
            Err(v) => {
                for line in &v.trace {
                    println!("{line}");
                }
                panic!("{v}");
            }
        }
        return;
    }
    let n = env_u64("MRMM_SIM_SEEDS").unwrap_or(default);
    let first = env_u64("MRMM_SIM_FIRST").unwrap_or(0);
    let started = std::time::Instant::now();
    match run_many(first, n, config) {
        Ok(reports) => {
            let sum = |f: fn(&mrmm_sim::Report) -> u64| reports.iter().map(f).sum::<u64>();
            // A world that did nothing checks nothing: every seed must have sent messages (all
            // of them may be lost: barrier seed 1389, two robots whose leader crashed while the
            // network lost every re-publication of the other's arrival).
            if let Some(r) = reports.iter().find(|r| r.events == 0 || r.sent == 0) {
                panic!("{what} seed {}: the world did nothing ({} events, {} messages sent)", r.seed, r.events, r.sent);
            }
            if what.contains("barrier") || what.contains("system") {
                assert!(n == 0 || sum(|r| u64::from(r.barriers)) > 0, "{what}: {n} seeds passed no barrier");
                // The forger struck (and every robot refused it: a forgery taken fails the seed).
                assert!(n < 20 || sum(|r| u64::from(r.forged_refused)) > 0, "{what}: {n} seeds and no forgery reached a robot");
            }
            let headless: Vec<u64> = reports.iter().filter(|r| r.headless > 0).map(|r| r.seed).take(20).collect();
            if !headless.is_empty() {
                println!("seeds with missions nobody leads at the end (first 20): {headless:?}");
            }
            let unrecoverable: Vec<u64> = reports.iter().filter(|r| r.unrecoverable > 0).map(|r| r.seed).take(20).collect();
            if !unrecoverable.is_empty() {
                println!("seeds with unrecoverable missions at the end (first 20): {unrecoverable:?}");
            }
            println!(
                "{what}: {n} seeds in {:.1} s: {} events, {} messages, {} crashes, {} partitions, {} false suspicions, {} heads elected, {} controls acknowledged, {} operator commands ok, {} barriers passed; {} missions unrecoverable (a majority of their chain restarted); {} started anew ({} without every member), {} old-lineage heads fenced; {} missions nobody leads at the end (without disks); {} live members of missions with requirements checked to have them; {} missions paused at the end, their live members checked to hold; {} forged messages refused",
                started.elapsed().as_secs_f64(),
                sum(|r| r.events),
                sum(|r| r.messages),
                sum(|r| u64::from(r.crashes)),
                sum(|r| u64::from(r.partitions)),
                sum(|r| u64::from(r.suspicions)),
                sum(|r| u64::from(r.leads)),
                sum(|r| u64::from(r.acked)),
                sum(|r| u64::from(r.commands_ok)),
                sum(|r| u64::from(r.barriers)),
                sum(|r| u64::from(r.unrecoverable)),
                sum(|r| u64::from(r.anew)),
                sum(|r| u64::from(r.anew_short)),
                sum(|r| u64::from(r.fenced)),
                sum(|r| u64::from(r.headless)),
                sum(|r| u64::from(r.required_checked)),
                sum(|r| u64::from(r.paused_at_end)),
                sum(|r| u64::from(r.forged_refused)),
            );
        }
        Err(v) => panic!("{what}: {v}; replay with MRMM_SIM_SEED={} cargo test -p mrmm-sim --test <this file> -- --nocapture", v.seed),
    }
}
