//! The `soig` command: parses the arguments and calls the verb (`commands`), over the library.

mod args;
mod commands;

use std::process::ExitCode;

use clap::Parser;

use args::{Cli, Command};

// Each image allocates and frees several multi-MB buffers; glibc's malloc returns such blocks
// to the kernel at every free, so every image paid their page faults again (12% of a run).
// mimalloc keeps freed blocks for reuse.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> ExitCode {
    stop_cleanly_on_signals();
    threads_from_slurm();
    match Cli::parse().command {
        Command::Run(a) => commands::run(a),
        Command::Merge(a) => commands::merge(a),
        Command::Slurm(a) => commands::slurm(a),
        Command::K8s(a) => commands::k8s(a),
        Command::Train(a) => commands::train(a),
        Command::Verify(a) => commands::verify(a),
        Command::Export(a) => commands::export(a),
        Command::Eval(a) => commands::eval(a),
        Command::Study(a) => commands::study(a),
        Command::Compare(a) => commands::compare(a),
        Command::Tables(a) => commands::tables(a),
        Command::Enhance(a) => commands::enhance(a),
        Command::Detect(a) => commands::detect(a),
        Command::Schema(a) => commands::schema(a),
        Command::Experiment(a) => commands::experiment(a),
    }
}

/// Ctrl-C and SIGTERM (Slurm's scancel, a Kubernetes pod stop) stop cleanly: a thread waits
/// for them (blocked in every other thread, which inherit the mask; children get an empty one
/// from std), removes the locks and non-resumable staging directories, keeps a run's staging
/// directory and says how to resume it, and exits 128 + the signal: 130 and 143, the shells'.
fn stop_cleanly_on_signals() {
    use nix::sys::signal::{SigSet, Signal};
    let mut set = SigSet::empty();
    set.add(Signal::SIGINT);
    set.add(Signal::SIGTERM);
    if set.thread_block().is_err() {
        return;
    }
    std::thread::spawn(move || {
        let Ok(signal) = set.wait() else { return };
        for dir in soig::output::interrupt() {
            eprintln!(
                "interrupted ({signal}): the images finished so far are kept in {}; run the same command again to resume (only the missing images are rendered)",
                dir.display()
            );
        }
        std::process::exit(128 + signal as i32);
    });
}

/// In a Slurm job, as many threads as CPUs the task was given (`--cpus-per-task`), not as
/// the node has; `RAYON_NUM_THREADS`, when set, still decides.
fn threads_from_slurm() {
    let given = std::env::var("SLURM_CPUS_PER_TASK")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .filter(|&n| n > 0);
    if let (None, Some(n)) = (std::env::var_os("RAYON_NUM_THREADS"), given) {
        // Fails only if a pool exists already, which at the start of main it cannot.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global();
    }
}
