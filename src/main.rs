//! The `soig` command: a thin CLI over the library.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use soig::campaign::Campaign;

#[derive(Parser)]
#[command(
    name = "soig",
    version,
    about = "Space optical image generator: campaign file -> reproducible synthetic dataset of space debris images"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a campaign: render, enhance, split, and write the manifest.
    Run {
        /// The campaign TOML file.
        campaign: PathBuf,
        /// Output directory (default: the campaign's `output`, else `runs/<name>` beside it).
        #[arg(long)]
        out: Option<PathBuf>,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Recompute every hash of an output directory against its manifest.
    Verify {
        /// An output directory of `soig run`.
        dir: PathBuf,
    },
    /// Print the JSON Schema of the campaign format.
    Schema,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Run {
            campaign,
            out,
            quiet,
        } => {
            let campaign = match Campaign::load(&campaign) {
                Ok(c) => c,
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(2);
                }
            };
            let output = out.unwrap_or_else(|| campaign.output_dir.clone());
            match soig::pipeline::run(&campaign, &output, !quiet) {
                Ok(s) => {
                    println!(
                        "{} images in {:.1} s ({:.2} images/s) -> {}\ndigest {}",
                        s.images,
                        s.seconds,
                        s.images as f64 / s.seconds,
                        s.output.display(),
                        s.digest
                    );
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e:#}");
                    ExitCode::from(2)
                }
            }
        }
        Command::Verify { dir } => match soig::manifest::verify(&dir) {
            Ok((m, problems)) if problems.is_empty() => {
                println!("ok: {} files match, digest {}", m.files.len(), m.digest);
                ExitCode::SUCCESS
            }
            Ok((_, problems)) => {
                for p in &problems {
                    eprintln!("{p}");
                }
                eprintln!(
                    "verify failed: {} problem(s) in {}",
                    problems.len(),
                    dir.display()
                );
                ExitCode::from(1)
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(2)
            }
        },
        Command::Schema => {
            println!("{}", soig::campaign::schema_json());
            ExitCode::SUCCESS
        }
    }
}
