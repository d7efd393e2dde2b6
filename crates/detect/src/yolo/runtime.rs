//! Locating and loading ONNX Runtime: `$ORT_DYLIB_PATH`, else the `onnxruntime` Python package's
//! library (through the interpreter or by scanning `site-packages`), and the process-wide `ort`
//! environment built on it.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use ort::environment::Environment;

use super::YoloError;
use soig_base::python;

/// The process-wide ONNX Runtime environment (`ort` allows one per process).
static ORT_ENV: Mutex<Option<Environment>> = Mutex::new(None);

/// The environment, built on the first call on the library [`find_onnxruntime`] finds.
pub(super) fn ort_environment() -> Result<Environment, YoloError> {
    let mut guard = ORT_ENV.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(env) = guard.as_ref() {
        return Ok(env.clone());
    }
    let path = find_onnxruntime()?;
    let load_err = |message: String| YoloError::OnnxRuntimeLoad {
        path: path.clone(),
        message,
    };
    let builder = ort::init_from(&path).map_err(|e| load_err(e.to_string()))?;
    let env = builder
        .with_name("soig-yolo")
        .with_telemetry(false)
        .build()
        .map_err(|e| load_err(e.to_string()))?;
    *guard = Some(env.clone());
    Ok(env)
}

/// File name of the ONNX Runtime library inside a Python `onnxruntime/capi` folder.
fn is_ort_lib_name(name: &str) -> bool {
    let prefix = format!("{}onnxruntime", std::env::consts::DLL_PREFIX);
    name.starts_with(&prefix)
        && name.contains(std::env::consts::DLL_SUFFIX)
        && !name.contains("providers")
        && !name.contains("pybind")
}

/// The ONNX Runtime library inside an `onnxruntime` package folder, if any.
fn lib_in_package(pkg: &Path) -> Option<PathBuf> {
    let capi = pkg.join("capi");
    let mut found: Vec<PathBuf> = std::fs::read_dir(&capi)
        .ok()?
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_str().is_some_and(is_ort_lib_name))
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .collect();
    found.sort();
    found.into_iter().next()
}

/// `site-packages` folders under a prefix (a venv, `~/.local`).
fn site_packages_under(prefix: &Path) -> Vec<PathBuf> {
    let mut dirs = Vec::new();
    for lib in ["lib", "lib64"] {
        if let Ok(entries) = std::fs::read_dir(prefix.join(lib)) {
            let mut v: Vec<PathBuf> = entries
                .filter_map(|e| e.ok())
                .filter(|e| {
                    e.file_name()
                        .to_str()
                        .is_some_and(|n| n.starts_with("python"))
                })
                .map(|e| e.path().join("site-packages"))
                .filter(|p| p.is_dir())
                .collect();
            v.sort();
            dirs.extend(v);
        }
    }
    let win = prefix.join("Lib").join("site-packages");
    if win.is_dir() {
        dirs.push(win);
    }
    dirs
}

/// Where to look, for [`locate_onnxruntime`].
struct OrtSearch {
    dylib_env: Option<std::ffi::OsString>,
    pythons: Vec<PathBuf>,
    prefixes: Vec<PathBuf>,
}

fn locate_onnxruntime(search: &OrtSearch) -> Result<PathBuf, YoloError> {
    if let Some(p) = search.dylib_env.as_ref().filter(|p| !p.is_empty()) {
        let p = PathBuf::from(p);
        return if p.is_file() {
            Ok(p)
        } else {
            Err(YoloError::OrtDylibPathMissing(p))
        };
    }
    let mut searched = vec!["ORT_DYLIB_PATH (unset)".to_string()];
    const IMPORT: &str = "import onnxruntime, os; print(os.path.dirname(onnxruntime.__file__))";
    const SITES: &str = "import site, sys\nfor p in site.getsitepackages() + [site.getusersitepackages()] + sys.path: print(p)";
    let mut site_dirs: Vec<PathBuf> = Vec::new();
    for py in &search.pythons {
        searched.push(format!("`{} -c 'import onnxruntime'`", py.display()));
        if let Some(lines) = python::lines(py, IMPORT)
            && let Some(dir) = lines.last()
            && let Some(lib) = lib_in_package(Path::new(dir))
        {
            return Ok(lib);
        }
        if let Some(lines) = python::lines(py, SITES) {
            site_dirs.extend(lines.into_iter().map(PathBuf::from));
        }
    }
    let mut dirs: Vec<PathBuf> = search
        .prefixes
        .iter()
        .flat_map(|p| site_packages_under(p))
        .collect();
    dirs.extend(site_dirs);
    for dir in &dirs {
        if let Some(lib) = lib_in_package(&dir.join("onnxruntime")) {
            return Ok(lib);
        }
    }
    let prefixes: Vec<String> = search
        .prefixes
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    searched.push(format!(
        "site-packages under {}",
        if prefixes.is_empty() {
            "-".into()
        } else {
            prefixes.join(", ")
        }
    ));
    if !dirs.is_empty() {
        searched.push(format!("{} interpreter site dirs", dirs.len()));
    }
    Err(YoloError::OnnxRuntimeNotFound {
        searched: searched.join("; "),
    })
}

/// Where the ONNX Runtime shared library is: `$ORT_DYLIB_PATH`, else the `onnxruntime` Python
/// package's `capi/libonnxruntime.so*`, found via `python3 -c 'import onnxruntime, os;
/// print(os.path.dirname(onnxruntime.__file__))'` or by scanning `site-packages` under `./.venv`,
/// `$VIRTUAL_ENV`, `~/.local` and the interpreter's site dirs. The error tells the user to run the
/// project's setup (`pip install onnxruntime`) when absent.
pub fn find_onnxruntime() -> Result<PathBuf, YoloError> {
    // The project's .venv (scripts/setup.sh) in the current directory, else beside the
    // executable's repository, so soig finds it when started from anywhere.
    let repo_venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../.venv");
    let mut prefixes = vec![PathBuf::from(".venv"), repo_venv.clone()];
    if let Some(v) = std::env::var_os("VIRTUAL_ENV").filter(|v| !v.is_empty()) {
        prefixes.push(PathBuf::from(v));
    }
    if let Some(home) = std::env::var_os("HOME").filter(|v| !v.is_empty()) {
        prefixes.push(PathBuf::from(home).join(".local"));
    }
    let mut pythons = vec![
        PathBuf::from(".venv/bin/python3"),
        repo_venv.join("bin/python3"),
    ];
    pythons.retain(|p| p.is_file());
    pythons.push(PathBuf::from("python3"));
    locate_onnxruntime(&OrtSearch {
        dylib_env: std::env::var_os("ORT_DYLIB_PATH"),
        pythons,
        prefixes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_runtime_error_says_how_to_install() {
        let dir = std::env::temp_dir().join(format!("soig-yolo-no-ort-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let search = OrtSearch {
            dylib_env: None,
            pythons: vec![dir.join("no-such-python")],
            prefixes: vec![dir.join(".venv")],
        };
        let err = locate_onnxruntime(&search).unwrap_err();
        assert!(
            matches!(err, YoloError::OnnxRuntimeNotFound { .. }),
            "{err:?}"
        );
        let msg = err.to_string();
        assert!(msg.contains("pip install onnxruntime"), "{msg}");
        assert!(msg.contains("ORT_DYLIB_PATH"), "{msg}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_dylib_env_is_reported() {
        let search = OrtSearch {
            dylib_env: Some("/nonexistent/libonnxruntime.so".into()),
            pythons: vec![],
            prefixes: vec![],
        };
        let err = locate_onnxruntime(&search).unwrap_err();
        assert_eq!(
            err,
            YoloError::OrtDylibPathMissing("/nonexistent/libonnxruntime.so".into())
        );
    }

    #[test]
    fn finds_library_in_a_venv_layout() {
        let dir = std::env::temp_dir().join(format!("soig-yolo-venv-{}", std::process::id()));
        let capi = dir.join("lib/python3.11/site-packages/onnxruntime/capi");
        std::fs::create_dir_all(&capi).unwrap();
        for name in [
            "libonnxruntime_providers_shared.so",
            "onnxruntime_pybind11_state.so",
            "libonnxruntime.so.1.32.0",
        ] {
            std::fs::write(capi.join(name), b"").unwrap();
        }
        let search = OrtSearch {
            dylib_env: None,
            pythons: vec![],
            prefixes: vec![dir.clone()],
        };
        let found = locate_onnxruntime(&search).unwrap();
        if cfg!(target_os = "linux") {
            assert_eq!(found, capi.join("libonnxruntime.so.1.32.0"));
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
