//! The hostile-input corpus: every case in `tests/hostile/*.toml` runs the real `soig` binary on
//! malformed or hostile campaigns, TLEs, frames and models (issue #11), each in a fresh
//! directory with a 60 s limit, and must be refused cleanly: a non-zero exit, no panic, the
//! expected file, line and field in the message, no NaN or infinity written, and nothing outside
//! the output created, changed or deleted. `tests/hostile/README.md` describes a case's keys.

// Tests, benches and examples write their fixtures with std::fs; the product writes through the
// store (clippy.toml's disallowed-methods, checked on every target by scripts/test.sh).
#![allow(clippy::disallowed_methods)]

use std::collections::BTreeMap;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use serde::Deserialize;

/// The limit: a hostile input must not hang soig for longer.
const LIMIT: Duration = Duration::from_secs(60);

/// Cases run at once: the machine's cores, at most 4 (most cases end in milliseconds; the few
/// that render or load a model take a second or two).
fn workers() -> usize {
    std::thread::available_parallelism().map_or(2, |n| n.get().min(4))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Corpus {
    case: Vec<Case>,
}

/// One hostile input and what soig must say about it.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Case {
    name: String,
    /// The campaign written to `c.toml` (placeholders expanded, see `expand`).
    campaign: Option<String>,
    /// soig's arguments (placeholders expanded); default `run c.toml --quiet --out out`.
    args: Option<Vec<String>>,
    /// The folder soig starts in, relative to the case directory (default: that directory).
    cwd: Option<String>,
    /// The output path the command writes, relative to the case directory: excluded from the
    /// check that nothing else changed (default `out`; "" when the case has none).
    out: Option<String>,
    /// Substrings the error (stderr) must contain.
    expect: Vec<String>,
    /// Further text files, by path.
    #[serde(default)]
    files: BTreeMap<String, String>,
    /// Files copied from the repository (path -> repository path).
    #[serde(default)]
    copy: BTreeMap<String, String>,
    /// Files of raw bytes, given in hex.
    #[serde(default)]
    hex: BTreeMap<String, String>,
    /// Files cut to this many bytes (after the above are written).
    #[serde(default)]
    truncate: BTreeMap<String, u64>,
    /// FITS files built card by card.
    #[serde(default)]
    fits: BTreeMap<String, Fits>,
    /// Symbolic links (path -> target).
    #[serde(default)]
    symlink: BTreeMap<String, String>,
    /// Directories to create.
    #[serde(default)]
    dirs: Vec<String>,
    /// FIFOs to create (after the files).
    #[serde(default)]
    fifos: Vec<String>,
    /// soig commands run first, in order (their effects are the starting state).
    #[serde(default)]
    step: Vec<Step>,
    /// After the steps: files (re)written, text appended, paths removed, files copied from
    /// the repository, lines appended to a journal with their checksum, FIFOs made; a `*` in
    /// the last part of a path matches any run of characters (a staging folder's PID).
    #[serde(default)]
    then_files: BTreeMap<String, String>,
    #[serde(default)]
    then_append: BTreeMap<String, String>,
    #[serde(default)]
    then_remove: Vec<String>,
    #[serde(default)]
    then_copy: BTreeMap<String, String>,
    #[serde(default)]
    then_journal: BTreeMap<String, Vec<String>>,
    #[serde(default)]
    then_fifos: Vec<String>,
    /// After the steps: a file of zeros written here until its file system is full (a tmpfs
    /// of `tmpfs`), so that the attack runs on a full disk.
    #[serde(default)]
    then_fill: Vec<String>,
    /// After the steps: [path, text, replacement], the first occurrence replaced.
    #[serde(default)]
    then_replace: Vec<[String; 3]>,
    /// A tmpfs mounted here (as root; the case is skipped, saying so, otherwise).
    #[serde(default)]
    tmpfs: Vec<String>,
    /// Environment of the attack.
    #[serde(default)]
    env: BTreeMap<String, String>,
    /// Further paths (relative) that the attack may change: a lock a killed step left.
    #[serde(default)]
    may_change: Vec<String>,
    /// Folders whose own timestamps the attack may change (a temporary file made and removed
    /// in them, on a full disk); what they hold is checked as everywhere.
    #[serde(default)]
    may_touch: Vec<String>,
    /// The attack must succeed (done correctly rather than refused); then `verify` each of
    /// `verifies` and require each of `exists`.
    #[serde(default)]
    ok: bool,
    #[serde(default)]
    verifies: Vec<String>,
    #[serde(default)]
    exists: Vec<String>,
    /// Paths that must not exist after the attack (a stray file it was to remove).
    #[serde(default)]
    absent: Vec<String>,
}

/// A soig command run before the attack.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Step {
    args: Vec<String>,
    #[serde(default)]
    env: BTreeMap<String, String>,
    /// It may fail (a run killed on purpose by `SOIG_TEST_ABORT_AT`).
    #[serde(default)]
    may_fail: bool,
}

/// A FITS primary HDU: the header cards given (SIMPLE, BITPIX, NAXIS and NAXISn from the fields,
/// then `cards`), then `data_bytes` bytes of data, every 4-byte word `fill` (a big-endian f32).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Fits {
    bitpix: i32,
    naxis: Vec<u64>,
    #[serde(default)]
    cards: Vec<String>,
    data_bytes: u64,
    #[serde(default)]
    fill: f32,
}

fn nix_is_root() -> bool {
    std::fs::read_to_string("/proc/self/status").is_ok_and(|s| {
        s.lines()
            .find(|l| l.starts_with("Uid:"))
            .is_some_and(|l| l.split_whitespace().nth(2) == Some("0"))
    })
}

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The observer and one debris object from the repository's catalogue: six lines.
const OBJECTS_ONLY: &str = "[observer]\ntle_file = \"{catalog}\"\nnorad = 41335\n\
[[debris]]\ntle_file = \"{catalog}\"\nnorad = 37476";

/// `OBJECTS_ONLY` and a 64 px sensor, the smallest campaign that renders: nine lines.
const OBJECTS: &str = "{objects_only}\n[sensor]\nwidth_px = 64\nheight_px = 64";

/// `{objects}`, `{objects_only}`, `{catalog}`, `{model}`, `{frame}`, `{repo}`.
fn expand(text: &str) -> String {
    let r = repo();
    text.replace("{objects}", OBJECTS)
        .replace("{objects_only}", OBJECTS_ONLY)
        .replace(
            "{catalog}",
            &r.join("campaigns/data/catalog-2022-01-22.tle")
                .display()
                .to_string(),
        )
        .replace(
            "{model}",
            &r.join("models/soig-yolov8n-fixed.onnx")
                .display()
                .to_string(),
        )
        .replace(
            "{frame}",
            &r.join("tests/fixtures/neossat/NEOS_SCI_2024239174545_cord.fits")
                .display()
                .to_string(),
        )
        .replace("{repo}", &r.display().to_string())
}

fn fits_bytes(f: &Fits) -> Vec<u8> {
    let mut cards = vec![
        "SIMPLE  =                    T".to_string(),
        format!("BITPIX  = {:>20}", f.bitpix),
        format!("NAXIS   = {:>20}", f.naxis.len()),
    ];
    for (i, n) in f.naxis.iter().enumerate() {
        cards.push(format!("NAXIS{:<3}= {:>20}", i + 1, n));
    }
    cards.extend(f.cards.iter().cloned());
    cards.push("END".into());
    let mut bytes: Vec<u8> = cards
        .iter()
        .flat_map(|c| format!("{c:<80}").into_bytes())
        .collect();
    bytes.resize(bytes.len().div_ceil(2880) * 2880, b' ');
    let word = f.fill.to_be_bytes();
    bytes.extend((0..f.data_bytes).map(|i| word[i as usize % 4]));
    bytes
}

fn hex_bytes(hex: &str) -> Vec<u8> {
    let digits: Vec<u8> = hex.bytes().filter(|b| !b.is_ascii_whitespace()).collect();
    digits
        .chunks(2)
        .map(|p| u8::from_str_radix(std::str::from_utf8(p).unwrap(), 16).expect("hex"))
        .collect()
}

/// Lay out a case's files in `dir`.
fn prepare(case: &Case, dir: &Path) {
    let at = |p: &str| {
        let path = dir.join(p);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        path
    };
    for d in &case.dirs {
        std::fs::create_dir_all(dir.join(d)).unwrap();
    }
    if let Some(text) = &case.campaign {
        std::fs::write(at("c.toml"), expand(text)).unwrap();
    }
    for (p, text) in &case.files {
        std::fs::write(at(p), expand(text)).unwrap();
    }
    for (p, from) in &case.copy {
        std::fs::copy(repo().join(from), at(p)).unwrap();
    }
    for (p, hex) in &case.hex {
        std::fs::write(at(p), hex_bytes(hex)).unwrap();
    }
    for (p, f) in &case.fits {
        std::fs::write(at(p), fits_bytes(f)).unwrap();
    }
    for (p, len) in &case.truncate {
        std::fs::OpenOptions::new()
            .write(true)
            .open(dir.join(p))
            .unwrap()
            .set_len(*len)
            .unwrap();
    }
    for (p, target) in &case.symlink {
        std::os::unix::fs::symlink(target, at(p)).unwrap();
    }
    for p in &case.fifos {
        mkfifo(&at(p));
    }
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().unwrap().success();
    assert!(ok, "mkfifo {}", path.display());
}

/// `dir.join(p)`, a `*` in any of its parts matched against what is there (the first match).
fn glob(dir: &Path, p: &str) -> PathBuf {
    let mut path = dir.to_path_buf();
    for part in p.split('/') {
        let Some((pre, post)) = part.split_once('*') else {
            path.push(part);
            continue;
        };
        // A folder before a file: an experiment's `points/` holds each point's folder and,
        // beside it, the file of its values.
        let mut found: Vec<String> = std::fs::read_dir(&path)
            .into_iter()
            .flatten()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| {
                n.starts_with(pre) && n.ends_with(post) && n.len() >= pre.len() + post.len()
            })
            .collect();
        found.sort_by_key(|n| !path.join(n).is_dir());
        path.push(found.into_iter().next().unwrap_or_else(|| part.to_string()));
    }
    path
}

/// Run the steps and the edits after them: the error if a step that must succeed failed.
fn set_up(case: &Case, dir: &Path) -> Result<(), String> {
    use std::io::Write;
    for step in &case.step {
        let args: Vec<String> = step.args.iter().map(|a| expand(a)).collect();
        let o = Command::new(env!("CARGO_BIN_EXE_soig"))
            .args(&args)
            .current_dir(dir)
            .env("RAYON_NUM_THREADS", "1")
            .envs(&step.env)
            .stdin(Stdio::null())
            .output()
            .unwrap();
        if !o.status.success() && !step.may_fail {
            return Err(format!(
                "step soig {} failed: {}",
                args.join(" "),
                String::from_utf8_lossy(&o.stderr)
            ));
        }
    }
    for (p, text) in &case.then_files {
        let path = glob(dir, p);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, expand(text)).unwrap();
    }
    for (p, text) in &case.then_append {
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(glob(dir, p))
            .unwrap();
        f.write_all(expand(text).as_bytes()).unwrap();
    }
    for p in &case.then_remove {
        std::fs::remove_file(glob(dir, p)).unwrap();
    }
    for (p, from) in &case.then_copy {
        std::fs::copy(repo().join(from), glob(dir, p)).unwrap();
    }
    for (p, lines) in &case.then_journal {
        use sha2::Digest;
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(glob(dir, p))
            .unwrap();
        for l in lines {
            let sha: String = sha2::Sha256::digest(l.as_bytes())
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect();
            writeln!(f, "{l} {sha}").unwrap();
        }
    }
    for p in &case.then_fifos {
        mkfifo(&glob(dir, p));
    }
    for p in &case.then_fill {
        let mut f = std::fs::File::create(glob(dir, p)).unwrap();
        let zeros = vec![0u8; 1 << 16];
        // Until the disk is full: the error is the point.
        while f.write_all(&zeros).is_ok() {}
        let _ = f.sync_all();
    }
    for [p, from, to] in &case.then_replace {
        let path = glob(dir, p);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.contains(from.as_str()),
            "{from:?} not in {}",
            path.display()
        );
        std::fs::write(&path, text.replacen(from.as_str(), to, 1)).unwrap();
    }
    Ok(())
}

/// A tmpfs mounted at `path` while it lives.
struct Tmpfs(PathBuf);

impl Tmpfs {
    fn mount(path: &Path) -> Result<Tmpfs, String> {
        std::fs::create_dir_all(path).unwrap();
        let o = Command::new("mount")
            .args(["-t", "tmpfs", "-o", "size=64m", "tmpfs"])
            .arg(path)
            .output()
            .map_err(|e| e.to_string())?;
        if !o.status.success() {
            return Err(String::from_utf8_lossy(&o.stderr).into_owned());
        }
        Ok(Tmpfs(path.to_path_buf()))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// Every path under `dir` but `skip`, with what identifies its content: the target of a link,
/// else size, modification time and mode.
fn snapshot(dir: &Path, skip: &[PathBuf], into: &mut BTreeMap<PathBuf, String>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let path = e.unwrap().path();
        if skip.contains(&path) {
            continue;
        }
        let meta = std::fs::symlink_metadata(&path).unwrap();
        let id = if meta.file_type().is_symlink() {
            format!("-> {:?}", std::fs::read_link(&path).unwrap())
        } else {
            format!(
                "{} {} {:o}",
                meta.len(),
                meta.mtime_nsec() + meta.mtime() * 1_000_000_000,
                meta.mode()
            )
        };
        into.insert(path.clone(), id);
        if meta.is_dir() {
            snapshot(&path, skip, into);
        }
    }
}

/// Files under `dir` (links not followed) with a non-finite number (see `non_finite_file`).
fn non_finite(dir: &Path, found: &mut Vec<String>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries {
        let path = e.unwrap().path();
        let meta = std::fs::symlink_metadata(&path).unwrap();
        if meta.is_dir() {
            non_finite(&path, found);
        } else if meta.is_file() {
            non_finite_file(&path, found);
        }
    }
}

/// A FITS file with a non-finite pixel, or a text file with a NaN or infinity written out.
fn non_finite_file(path: &Path, found: &mut Vec<String>) {
    if path.extension().is_some_and(|x| x == "fits") {
        if let Ok((px, _, _)) = soig::fits::read_f64(path)
            && px.iter().any(|v| !v.is_finite())
        {
            found.push(path.display().to_string());
        }
    } else if let Ok(text) = std::fs::read_to_string(path) {
        let mut words = text.split(|c: char| !c.is_ascii_alphanumeric());
        if words.any(|w| w == "NaN" || w == "nan" || w == "inf") {
            found.push(path.display().to_string());
        }
    }
}

/// Run one case; the ways it went wrong.
fn run(case: &Case) -> Vec<String> {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("case");
    std::fs::create_dir(&dir).unwrap();
    prepare(case, &dir);
    let mut mounts = Vec::new();
    for p in &case.tmpfs {
        if !nix_is_root() {
            eprintln!("{}: skipped: mounting a tmpfs needs root", case.name);
            return Vec::new();
        }
        match Tmpfs::mount(&dir.join(p)) {
            Ok(m) => mounts.push(m),
            Err(e) => {
                eprintln!("{}: skipped: cannot mount a tmpfs: {e}", case.name);
                return Vec::new();
            }
        }
    }
    if let Err(e) = set_up(case, &dir) {
        return vec![e];
    }
    let out = case.out.as_deref().unwrap_or("out");
    let out_path = dir.join(out);
    let skip: Vec<PathBuf> = std::iter::once(out_path.clone())
        .chain(case.may_change.iter().map(|p| glob(&dir, p)))
        .collect();
    let mut before = BTreeMap::new();
    snapshot(&dir, &skip, &mut before);

    let default_args = ["run", "c.toml", "--quiet", "--out", "out"].map(String::from);
    let args: Vec<String> = match &case.args {
        Some(a) => a.iter().map(|s| expand(s)).collect(),
        None => default_args.to_vec(),
    };
    let stderr_path = tmp.path().join("stderr");
    let stdout_path = tmp.path().join("stdout");
    let started = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_soig"))
        .args(&args)
        .current_dir(dir.join(case.cwd.as_deref().unwrap_or(".")))
        .env("RAYON_NUM_THREADS", "1")
        .envs(&case.env)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&stdout_path).unwrap())
        .stderr(std::fs::File::create(&stderr_path).unwrap())
        .spawn()
        .expect("soig starts");
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break Some(s);
        }
        if started.elapsed() > LIMIT {
            child.kill().unwrap();
            child.wait().unwrap();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let err = String::from_utf8_lossy(&std::fs::read(&stderr_path).unwrap()).into_owned();
    // What soig said: stderr, and stdout (`compare` reports there).
    let said = err.clone() + &String::from_utf8_lossy(&std::fs::read(&stdout_path).unwrap());
    let mut problems = Vec::new();
    match status {
        None => problems.push(format!("still running after {LIMIT:?}: killed")),
        Some(s) if s.code().is_none() => problems.push(format!("ended by a signal: {s}")),
        Some(s) if s.success() && !case.ok => problems.push("exit 0".into()),
        Some(s) if !s.success() && case.ok => problems.push(format!("failed: {s}")),
        Some(_) => {}
    }
    for v in &case.verifies {
        let o = Command::new(env!("CARGO_BIN_EXE_soig"))
            .args(["verify", &glob(&dir, v).display().to_string()])
            .output()
            .unwrap();
        if !o.status.success() {
            problems.push(format!(
                "{v} does not verify: {}",
                String::from_utf8_lossy(&o.stderr)
            ));
        }
    }
    for e in &case.exists {
        if std::fs::symlink_metadata(dir.join(e)).is_err() {
            problems.push(format!("{e} is missing"));
        }
    }
    for a in &case.absent {
        if std::fs::symlink_metadata(glob(&dir, a)).is_ok() {
            problems.push(format!("{a} is still there"));
        }
    }
    if err.contains("panicked") {
        problems.push("panicked".into());
    }
    for e in &case.expect {
        if !said.contains(e.as_str()) {
            problems.push(format!("no {e:?} in the error"));
        }
    }
    if !dir.is_dir() {
        problems.push(format!(
            "deleted the case folder {}, said: {err}",
            dir.display()
        ));
        return problems;
    }
    let mut after = BTreeMap::new();
    snapshot(&dir, &skip, &mut after);
    let touched: Vec<PathBuf> = case.may_touch.iter().map(|p| dir.join(p)).collect();
    for (path, id) in &before {
        match after.get(path) {
            Some(_) if touched.contains(path) => {}
            None => problems.push(format!("deleted {}", path.display())),
            Some(now) if now != id => problems.push(format!("changed {}", path.display())),
            Some(_) => {}
        }
    }
    for path in after.keys().filter(|p| !before.contains_key(*p)) {
        problems.push(format!("created {}", path.display()));
    }
    // What soig wrote: the output and anything it created or changed beside it.
    let mut nan = Vec::new();
    if !out.is_empty() {
        non_finite(&out_path, &mut nan);
    }
    for (path, id) in &after {
        if before.get(path) != Some(id) && path.is_file() {
            non_finite_file(path, &mut nan);
        }
    }
    problems.extend(nan.into_iter().map(|f| format!("non-finite number in {f}")));
    drop(mounts);
    if !problems.is_empty() {
        problems.push(format!(
            "soig {} ({:.1} s) said: {}",
            args.join(" "),
            started.elapsed().as_secs_f64(),
            err.trim_end()
        ));
    }
    problems
}

fn corpus() -> Vec<Case> {
    let dir = repo().join("tests/hostile");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
        .iter()
        .flat_map(|f| {
            let text = std::fs::read_to_string(f).unwrap();
            let c: Corpus =
                toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
            c.case
        })
        .collect()
}

#[test]
fn hostile_inputs_are_refused_cleanly() {
    let cases = corpus();
    let mut names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), cases.len(), "case names must be unique");
    // The floor for this corpus.
    assert!(cases.len() >= 60, "{} cases", cases.len());

    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let started = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..workers() {
            s.spawn(|| {
                while let Some(case) = cases.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let problems = run(case);
                    if !problems.is_empty() {
                        failures.lock().unwrap().push(format!(
                            "{}:\n  {}",
                            case.name,
                            problems.join("\n  ")
                        ));
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    eprintln!(
        "{} hostile cases in {:.1} s, {} failed",
        cases.len(),
        started.elapsed().as_secs_f64(),
        failures.len()
    );
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}
