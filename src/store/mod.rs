//! The store: soig's output-safety rules, and the only code that creates, replaces or deletes
//! files (`clippy.toml` disallows `std::fs`'s writers, `csv::Writer::from_path` and the `image`
//! crate's `save` everywhere else; the crates below this one write no files at all, but for
//! cfitsio, which is handed a path inside a staging directory or a temporary file of [`fs`]).
//!
//! # Rules
//!
//! 1. An output directory is written whole or not at all ([`output`]): filled in a hidden
//!    staging directory, then moved into place; an existing one is replaced only if it is
//!    empty or soig's (its manifest lists every file in it), never `/`, the current directory,
//!    an input or its folder, a folder inside another soig output, or a mount point; a lock
//!    keeps two runs apart. A refusal comes before anything is made: no lock, no folder.
//! 2. A file written in place (outside a staging directory) is written atomically:
//!    [`fs::write`] (temporary file beside it, synced, renamed), so a full disk or a kill leaves
//!    the old file, never a truncated one; a user's file is only ever replaced that way
//!    ([`fs::replace`], keeping its permissions).
//! 3. A file in a staging directory is new ([`fs::create`]: never over an existing file; a
//!    partial one is removed on error); the directory is the unit that moves into place, and
//!    the journal ([`journal`]) hashes what a resumable run wrote.
//! 4. Only soig's files and folders are removed or renamed ([`fs::remove_file`],
//!    [`fs::remove_dir_all`], [`fs::rename`]); the caller knows they are soig's.
//! 5. A run checks its disk holds what it will write before the first image ([`disk`]).
//!
//! # Who writes through what
//!
//! | verb | output | primitives |
//! |---|---|---|
//! | `run` (and Python's `run`), shards | staged, resumable: `write_resumable` | `create` (images, truth, labels, dataset, report, collects, records), cfitsio (FITS), `create_dir_all`, manifest by `write` |
//! | `merge` | staged: `write_replacing` | `link_or_copy`, `create`, manifest by `write` |
//! | `study`, `enhance` (convert), `detect`, `tables --out` | staged: `write_replacing` | `create`, `write` (plots, manifest) |
//! | `export` | staged: `write_replacing` (its manifest marks an export, which only an export replaces) | `create`, manifest by `write` |
//! | `train` (into a finished output) | in place, `train/` of soig's (`check_folder`: never an output holding its starting weights) | `remove_dir_all`, `write` (script, manifest), `create_log`, `copy` (model) |
//! | `tables --readme` | the user's README, in place | `replace` |
//! | `experiment` | in place, a folder of its own (`check_folder`; one killed before its manifest is resumed) | `create_dirs` (taken back if empty on failure), `write`, `remove_dir_all` (plots) |
//! | `slurm`, `k8s` | in place, scripts soig wrote (`check_folder`), their record last | `create_dirs` (taken back if empty on failure), `write`, `write_executable` |
//! | Python's `write_frame` | the path the caller names | `write`, `write_by` (FITS) |

pub mod disk;
pub mod fs;
pub mod journal;
pub mod manifest;
pub mod output;
