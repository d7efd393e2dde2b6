//! Launchers: the files that run a campaign as N shards on a cluster engine and merge them.
//! `slurm` writes a Slurm job array (one `soig run --shard K/N` per task), a merge job and a
//! `submit.sh` that chains them with `afterok`; `k8s` writes a Kubernetes Indexed Job (one
//! `soig run --shard auto/N` per completion index, outputs on a shared volume), a merge Job
//! and a `submit.sh` that applies the second once the first is complete. Every shard output
//! is named as `soig run --shard` names it (`OUT-shard-K-of-N`), so the merge lists them.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use serde_json::{Value, json};

use crate::shard::Shard;
use crate::store::fs;

/// What the jobs run: `soig run CAMPAIGN --set ...` as `shards` shards, merged into `out`.
pub struct Launch {
    /// The `soig` the jobs call.
    pub soig: PathBuf,
    pub campaign: PathBuf,
    /// `--set key=value` overrides, passed on to every shard.
    pub sets: Vec<String>,
    /// The merged output; shard K writes `OUT-shard-K-of-N`.
    pub out: PathBuf,
    pub shards: u64,
    /// The campaign's name, from which job names are made.
    pub name: String,
    /// Slurm only: `#SBATCH` options of every job (partition, account, time, memory, CPUs,
    /// or any raw option), each `--option=value`, in order (see [`sbatch_options`]).
    pub sbatch: Vec<String>,
}

/// What `soig slurm` asks of the cluster for each job, as sbatch would take it.
#[derive(Default)]
pub struct SlurmResources {
    pub partition: Option<String>,
    pub account: Option<String>,
    /// Wall-time limit: `MM`, `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM` or `D-HH:MM:SS`.
    pub time: Option<String>,
    /// Memory per node: a number of megabytes, or with a unit suffix K, M, G or T.
    pub mem: Option<String>,
    pub cpus_per_task: Option<u32>,
    /// Raw sbatch options (`--qos=high`), written as they are, after the others.
    pub raw: Vec<String>,
}

/// The `#SBATCH` options of `r`, checked enough that a typo fails here rather than at submit:
/// values are single words, the time and memory in sbatch's formats, raw options start `-`.
pub fn sbatch_options(r: &SlurmResources) -> anyhow::Result<Vec<String>> {
    let word = |flag: &str, v: &str| {
        anyhow::ensure!(
            !v.is_empty() && !v.chars().any(|c| c.is_whitespace() || c.is_control()),
            "--{flag} {v:?}: must be one word without spaces"
        );
        Ok(format!("--{flag}={v}"))
    };
    let digits = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_digit());
    let mut out = Vec::new();
    if let Some(p) = &r.partition {
        out.push(word("partition", p)?);
    }
    if let Some(a) = &r.account {
        out.push(word("account", a)?);
    }
    if let Some(t) = &r.time {
        let (days, clock) = match t.split_once('-') {
            Some((d, rest)) => (Some(d), rest),
            None => (None, t.as_str()),
        };
        let fields: Vec<&str> = clock.split(':').collect();
        let ok = days.is_none_or(digits) && fields.iter().all(|f| digits(f)) && fields.len() <= 3;
        anyhow::ensure!(
            ok,
            "--time {t:?}: expected MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS"
        );
        out.push(format!("--time={t}"));
    }
    if let Some(m) = &r.mem {
        let number = m.strip_suffix(['K', 'M', 'G', 'T']).unwrap_or(m);
        anyhow::ensure!(
            digits(number),
            "--mem {m:?}: expected megabytes, or a number with K, M, G or T (e.g. 4G)"
        );
        out.push(format!("--mem={m}"));
    }
    if let Some(n) = r.cpus_per_task {
        out.push(format!("--cpus-per-task={n}"));
    }
    for raw in &r.raw {
        anyhow::ensure!(
            raw.starts_with('-') && !raw.contains('\n'),
            "--sbatch {raw:?}: expected one sbatch option, e.g. --sbatch=--qos=high"
        );
        out.push(raw.clone());
    }
    Ok(out)
}

/// One file a launcher writes.
pub struct File {
    pub name: &'static str,
    pub text: String,
    /// Runnable (`submit.sh`).
    pub executable: bool,
}

impl Launch {
    fn shard_dirs(&self) -> Vec<PathBuf> {
        (0..self.shards)
            .map(|index| {
                Shard {
                    index,
                    count: self.shards,
                }
                .output_dir(&self.out)
            })
            .collect()
    }

    /// `soig run CAMPAIGN --quiet --set ...` (without `--shard` and `--out`).
    fn run_args(&self) -> Vec<String> {
        let mut args = vec![
            self.soig.display().to_string(),
            "run".into(),
            self.campaign.display().to_string(),
            "--quiet".into(),
        ];
        for s in &self.sets {
            args.extend(["--set".into(), s.clone()]);
        }
        args
    }

    /// `soig merge SHARD... --out OUT --quiet`.
    fn merge_args(&self) -> Vec<String> {
        let mut args = vec![self.soig.display().to_string(), "merge".into()];
        args.extend(self.shard_dirs().iter().map(|d| d.display().to_string()));
        args.extend([
            "--out".into(),
            self.out.display().to_string(),
            "--quiet".into(),
        ]);
        args
    }
}

/// `word` as one shell word: as it is when it holds only characters the shell leaves alone,
/// else in single quotes (a `'` inside written `'\''`).
pub fn shell_word(word: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_./,:=+@%-".contains(c);
    if !word.is_empty() && word.chars().all(plain) {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

fn shell_line(args: &[String]) -> String {
    args.iter()
        .map(|a| shell_word(a))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `name` reduced to the characters a job name may hold everywhere (a Kubernetes object name:
/// lower-case letters, digits and `-`, at most 63), prefixed `soig-`.
fn job_name(name: &str) -> String {
    let mut s = String::from("soig-");
    for c in name.chars() {
        let c = c.to_ascii_lowercase();
        s.push(if c.is_ascii_alphanumeric() { c } else { '-' });
    }
    // Room for the `-merge` suffix within 63.
    s.truncate(57);
    s.trim_end_matches('-').to_string()
}

/// The Slurm files: `array.sbatch`, `merge.sbatch`, `submit.sh`. Logs go to the folder the
/// scripts are submitted from (`submit.sh` submits from its own), as `NAME-%A_%a.out` for the
/// array (job id, task id) and `NAME-merge-%j.out` for the merge.
pub fn slurm(l: &Launch) -> Vec<File> {
    let name = job_name(&l.name);
    let last = l.shards - 1;
    // The task id is a number, so it may stand unquoted after the quoted output path.
    let out = format!(
        "{}-shard-${{SLURM_ARRAY_TASK_ID}}-of-{}",
        shell_word(&l.out.display().to_string()),
        l.shards
    );
    let options: String = l.sbatch.iter().map(|o| format!("#SBATCH {o}\n")).collect();
    let array = format!(
        "#!/bin/bash\n\
         #SBATCH --job-name={name}\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --output={name}-%A_%a.out\n\
         {options}\
         # One task per shard: task K renders shard K of {n}, named in full so that one task\n\
         # run again alone (sbatch --array=K) renders its shard. A task requeued resumes.\n\
         set -euo pipefail\n\
         exec {run} --shard \"${{SLURM_ARRAY_TASK_ID}}/{n}\" --out {out}\n",
        n = l.shards,
        run = shell_line(&l.run_args()),
    );
    let merge = format!(
        "#!/bin/bash\n\
         #SBATCH --job-name={name}-merge\n\
         #SBATCH --output={name}-merge-%j.out\n\
         {options}\
         # Runs after every task of the array succeeded (submit.sh: --dependency=afterok).\n\
         set -euo pipefail\n\
         exec {}\n",
        shell_line(&l.merge_args())
    );
    let submit = "#!/bin/bash\n\
         # Submit the shard array, then the merge to run once all its tasks succeeded\n\
         # (cancelled if one fails). Prints the two job ids.\n\
         set -euo pipefail\n\
         cd \"$(dirname \"$0\")\"\n\
         array=$(sbatch --parsable array.sbatch)\n\
         array=${array%%;*}\n\
         merge=$(sbatch --parsable --dependency=afterok:\"$array\" --kill-on-invalid-dep=yes merge.sbatch)\n\
         merge=${merge%%;*}\n\
         echo \"array job $array\"\n\
         echo \"merge job $merge\"\n"
        .to_string();
    vec![
        File {
            name: "array.sbatch",
            text: array,
            executable: false,
        },
        File {
            name: "merge.sbatch",
            text: merge,
            executable: false,
        },
        File {
            name: "submit.sh",
            text: submit,
            executable: true,
        },
    ]
}

/// Where the shared volume is mounted in every pod; campaign and output paths are relative
/// to it (the pods' working directory).
pub const MOUNT: &str = "/data";

/// A Job running `command` in `image` with the claim `claim` mounted at `MOUNT`.
fn job(name: &str, image: &str, claim: &str, command: Vec<String>, env: Value) -> Value {
    json!({
        "apiVersion": "batch/v1",
        "kind": "Job",
        "metadata": {"name": name, "labels": {"app": "soig"}},
        "spec": {
            "template": {
                "metadata": {"labels": {"app": "soig", "job": name}},
                "spec": {
                    "restartPolicy": "Never",
                    "containers": [{
                        "name": "soig",
                        "image": image,
                        "workingDir": MOUNT,
                        "command": command,
                        "env": env,
                        "volumeMounts": [{"name": "data", "mountPath": MOUNT}],
                    }],
                    "volumes": [{"name": "data", "persistentVolumeClaim": {"claimName": claim}}],
                },
            },
        },
    })
}

/// The two Kubernetes Jobs: the Indexed Job of the shards and the merge Job.
pub fn k8s_jobs(l: &Launch, image: &str, claim: &str) -> (Value, Value) {
    let name = job_name(&l.name);
    let mut run = l.run_args();
    // `$(SHARD)` is expanded by Kubernetes from the container's env, below.
    let out = format!("{}-shard-$(SHARD)-of-{}", l.out.display(), l.shards);
    run.extend([
        "--shard".into(),
        format!("auto/{}", l.shards),
        "--out".into(),
        out,
    ]);
    let env = json!([{"name": "SHARD", "valueFrom": {"fieldRef": {
        "fieldPath": "metadata.annotations['batch.kubernetes.io/job-completion-index']"
    }}}]);
    let mut shards = job(&name, image, claim, run, env);
    let spec = &mut shards["spec"];
    spec["completionMode"] = json!("Indexed");
    spec["completions"] = json!(l.shards);
    spec["parallelism"] = json!(l.shards);
    // A failed shard is retried on its own (and resumes what its pod finished), twice.
    spec["backoffLimitPerIndex"] = json!(2);
    let mut merge = job(
        &format!("{name}-merge"),
        image,
        claim,
        l.merge_args(),
        json!([]),
    );
    merge["spec"]["backoffLimit"] = json!(1);
    (shards, merge)
}

/// The Kubernetes files: `shards.yaml`, `merge.yaml`, `submit.sh`. Each Job fails after
/// `deadline_s` (its `activeDeadlineSeconds`), and submit.sh gives up on it then, or sooner
/// when its pods cannot pull the image: never a wait for ever on pods that stay Pending.
pub fn k8s(l: &Launch, image: &str, claim: &str, deadline_s: u64) -> Vec<File> {
    let (mut shards, mut merge) = k8s_jobs(l, image, claim);
    for job in [&mut shards, &mut merge] {
        job["spec"]["activeDeadlineSeconds"] = json!(deadline_s);
    }
    let name = job_name(&l.name);
    let submit = SUBMIT_K8S
        .replace("@DEADLINE@", &deadline_s.to_string())
        .replace("@IMAGE@", &shell_word(image))
        .replace("@NAME@", &name);
    vec![
        File {
            name: "shards.yaml",
            text: yaml(&shards),
            executable: false,
        },
        File {
            name: "merge.yaml",
            text: yaml(&merge),
            executable: false,
        },
        File {
            name: "submit.sh",
            text: submit,
            executable: true,
        },
    ]
}

/// The Kubernetes submit.sh; `@NAME@`, `@IMAGE@` and `@DEADLINE@` are filled in.
const SUBMIT_K8S: &str = r#"#!/bin/bash
# Start the shards, wait until every index has completed, then start the merge.
set -euo pipefail
cd "$(dirname "$0")"
# Each Job has @DEADLINE@ s (`soig k8s --deadline`; Kubernetes fails it after that, its
# activeDeadlineSeconds); this script gives up on a Job as long after it started, sooner with
# $SOIG_K8S_DEADLINE_S, and after $SOIG_K8S_PULL_GRACE_S (300) s of pods that cannot pull
# the image. It polls every $SOIG_K8S_POLL_S (10) s.
deadline=${SOIG_K8S_DEADLINE_S:-@DEADLINE@}
pull_grace=${SOIG_K8S_PULL_GRACE_S:-300}
poll=${SOIG_K8S_POLL_S:-10}
# The Job's pods, one a line: name, phase, why a container waits.
pods() {
  kubectl get pods -l "job-name=$1" -o jsonpath='{range .items[*]}{.metadata.name} {.status.phase} {.status.containerStatuses[*].state.waiting.reason}{"\n"}{end}' 2>/dev/null || true
}
# A Job ends Complete or Failed: wait for either (`kubectl wait` on one condition never
# returns for the other), and stop with the failure, or when it is past its deadline.
finished() {
  local started=$SECONDS waited state now
  while true; do
    state=$(kubectl get "job/$1" -o jsonpath='{range .status.conditions[?(@.status=="True")]}{.type} {end}')
    case " $state " in
      *" Complete "*) return 0 ;;
      *" Failed "*) echo "job $1 failed:" >&2; kubectl logs "job/$1" >&2 || true; return 1 ;;
    esac
    waited=$((SECONDS - started))
    now=$(pods "$1")
    if [ "$waited" -ge "$deadline" ]; then
      echo "job $1: not complete after $waited s, its deadline (soig k8s --deadline, or \$SOIG_K8S_DEADLINE_S); giving up. Its pods (name, phase, waiting reason):" >&2
      echo "${now:-  (none)}" >&2
      echo "The Job is left as it is: kubectl describe job/$1; kubectl delete job/$1" >&2
      return 1
    fi
    if [ "$waited" -ge "$pull_grace" ] && grep -qE 'ErrImagePull|ImagePullBackOff|InvalidImageName' <<<"$now"; then
      echo "job $1: its pods cannot pull the image "@IMAGE@" after $waited s; giving up. Its pods (name, phase, waiting reason):" >&2
      echo "$now" >&2
      echo "Push the image where the cluster can pull it (or give soig k8s --image), then: kubectl delete job/$1; ./submit.sh" >&2
      return 1
    fi
    sleep "$poll"
  done
}
kubectl apply -f shards.yaml
finished @NAME@
kubectl apply -f merge.yaml
finished @NAME@-merge
kubectl logs job/@NAME@-merge
"#;

/// `v` as a block YAML document. Strings are written as JSON strings, which YAML reads as
/// double-quoted scalars, so no value is ever taken for a number, a boolean or a comment.
pub fn yaml(v: &Value) -> String {
    let mut s = String::new();
    block(v, 0, &mut s);
    s
}

fn scalar(v: &Value) -> String {
    match v {
        Value::Array(a) if a.is_empty() => "[]".into(),
        Value::Object(o) if o.is_empty() => "{}".into(),
        other => other.to_string(),
    }
}

/// A mapping key: bare when it is a plain name (`apiVersion`), else quoted.
fn key(k: &str) -> String {
    if !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        k.to_string()
    } else {
        Value::from(k).to_string()
    }
}

fn nested(v: &Value) -> bool {
    matches!(v, Value::Array(a) if !a.is_empty()) || matches!(v, Value::Object(o) if !o.is_empty())
}

fn block(v: &Value, indent: usize, s: &mut String) {
    let pad = " ".repeat(indent);
    match v {
        Value::Object(o) if !o.is_empty() => {
            for (k, v) in o {
                if nested(v) {
                    let _ = writeln!(s, "{pad}{}:", key(k));
                    block(v, indent + 2, s);
                } else {
                    let _ = writeln!(s, "{pad}{}: {}", key(k), scalar(v));
                }
            }
        }
        Value::Array(a) if !a.is_empty() => {
            for v in a {
                if nested(v) {
                    // The item's first line starts with `- ` in place of its indentation.
                    let mut item = String::new();
                    block(v, indent + 2, &mut item);
                    let _ = write!(s, "{pad}- {}", &item[indent + 2..]);
                } else {
                    let _ = writeln!(s, "{pad}- {}", scalar(v));
                }
            }
        }
        other => {
            let _ = writeln!(s, "{pad}{}", scalar(other));
        }
    }
}

/// What `write` wrote into a folder: file name to sha256, so a second run can tell a file it
/// wrote and nobody edited (which it may replace) from one a user edited or made.
const WRITTEN: &str = ".soig-launch.json";

/// Write `files` into `dir` (created if missing). A file already there is replaced only if it
/// is what soig wrote there last, unedited, or is already the new text: a hand-edited
/// `array.sbatch` (an added `#SBATCH --partition`) or a user's own file of that name is never
/// overwritten; nothing is written unless every file can be. `keep` (the campaign) may not be
/// `dir` or inside it.
pub fn write(dir: &Path, files: &[File], keep: &[&Path]) -> anyhow::Result<()> {
    use sha2::{Digest, Sha256};
    crate::output::check_folder(dir, keep)?;
    let sha = |t: &[u8]| crate::hash::hex(&Sha256::digest(t));
    let record = dir.join(WRITTEN);
    let mut written: std::collections::BTreeMap<String, String> =
        crate::hash::read_regular_to_string(&record)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or_default();
    for f in files {
        let path = dir.join(f.name);
        if std::fs::symlink_metadata(&path).is_err() {
            continue;
        }
        let now = crate::hash::read_regular_to_string(&path)
            .with_context(|| format!("{} exists and cannot be read as a file", path.display()))?;
        if now != f.text && written.get(f.name) != Some(&sha(now.as_bytes())) {
            anyhow::bail!(
                "{} was edited since soig wrote it, or is not soig's: refusing to overwrite it (move it away, or write the scripts elsewhere with --scripts)",
                path.display()
            );
        }
    }
    let made = fs::create_dirs(dir)?;
    for f in files {
        written.insert(f.name.to_string(), sha(f.text.as_bytes()));
    }
    // The record last: a file written before a failure (a full disk) is the new text, which
    // the next run accepts; the record never claims a file that is not there.
    let result = files
        .iter()
        .try_for_each(|f| {
            let path = dir.join(f.name);
            if f.executable {
                fs::write_executable(&path, &f.text)
            } else {
                fs::write(&path, &f.text)
            }
        })
        .and_then(|()| fs::write(&record, serde_json::to_string_pretty(&written)? + "\n"));
    if result.is_err() {
        fs::remove_empty_dirs(&made);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn launch(shards: u64) -> Launch {
        Launch {
            soig: "/opt/soig/bin/soig".into(),
            campaign: "/home/me/my campaigns/quick start.toml".into(),
            sets: vec!["images=6".into(), "name=it's".into()],
            out: "/scratch/run s/q".into(),
            shards,
            name: "Quick_Start".into(),
            sbatch: Vec::new(),
        }
    }

    fn text<'a>(files: &'a [File], name: &str) -> &'a str {
        &files.iter().find(|f| f.name == name).unwrap().text
    }

    #[test]
    fn shell_words_quote_what_the_shell_would_split() {
        assert_eq!(shell_word("a/b-c_1.toml"), "a/b-c_1.toml");
        assert_eq!(shell_word("a b"), "'a b'");
        assert_eq!(shell_word("it's"), r"'it'\''s'");
        assert_eq!(shell_word("$HOME"), "'$HOME'");
        assert_eq!(shell_word(""), "''");
    }

    #[test]
    fn job_names_are_kubernetes_names() {
        assert_eq!(job_name("Quick_Start"), "soig-quick-start");
        let long = job_name(&"x".repeat(100));
        assert!(long.len() <= 57 && long.starts_with("soig-x"));
    }

    #[test]
    fn slurm_array_runs_one_shard_per_task_and_merge_waits_for_it() {
        let files = slurm(&launch(3));
        let array = text(&files, "array.sbatch");
        assert!(array.starts_with("#!/bin/bash\n#SBATCH --job-name=soig-quick-start\n"));
        assert!(array.contains("\n#SBATCH --array=0-2\n"));
        assert!(array.contains("\n#SBATCH --output=soig-quick-start-%A_%a.out\n"));
        assert!(array.contains(
            "exec /opt/soig/bin/soig run '/home/me/my campaigns/quick start.toml' --quiet \
             --set images=6 --set 'name=it'\\''s' --shard \"${SLURM_ARRAY_TASK_ID}/3\" \
             --out '/scratch/run s/q'-shard-${SLURM_ARRAY_TASK_ID}-of-3\n"
        ));
        let merge = text(&files, "merge.sbatch");
        assert!(merge.contains(
            "exec /opt/soig/bin/soig merge '/scratch/run s/q-shard-0-of-3' \
             '/scratch/run s/q-shard-1-of-3' '/scratch/run s/q-shard-2-of-3' \
             --out '/scratch/run s/q' --quiet\n"
        ));
        let submit = text(&files, "submit.sh");
        assert!(submit.contains("--dependency=afterok:\"$array\""));
        assert!(
            files
                .iter()
                .find(|f| f.name == "submit.sh")
                .unwrap()
                .executable
        );
    }

    #[test]
    fn sbatch_options_reach_both_jobs_and_typos_are_refused() {
        let r = SlurmResources {
            partition: Some("p".into()),
            account: Some("proj-1".into()),
            time: Some("01:00:00".into()),
            mem: Some("4G".into()),
            cpus_per_task: Some(4),
            raw: vec!["--qos=high".into()],
        };
        let mut l = launch(2);
        l.sbatch = sbatch_options(&r).unwrap();
        let files = slurm(&l);
        let lines = "#SBATCH --partition=p\n#SBATCH --account=proj-1\n#SBATCH --time=01:00:00\n\
                     #SBATCH --mem=4G\n#SBATCH --cpus-per-task=4\n#SBATCH --qos=high\n";
        for f in ["array.sbatch", "merge.sbatch"] {
            assert!(text(&files, f).contains(lines), "{}", text(&files, f));
        }
        let with_time = |time: &str| SlurmResources {
            time: Some(time.into()),
            ..Default::default()
        };
        for time in ["30", "30:00", "1-12", "1-12:30", "2-00:00:00"] {
            let r = with_time(time);
            assert_eq!(sbatch_options(&r).unwrap(), [format!("--time={time}")]);
        }
        let bad = [
            with_time("1h"),
            with_time("1:2:3:4"),
            SlurmResources {
                mem: Some("4GB".into()),
                ..Default::default()
            },
            SlurmResources {
                partition: Some("a b".into()),
                ..Default::default()
            },
            SlurmResources {
                raw: vec!["qos=high".into()],
                ..Default::default()
            },
        ];
        for r in bad {
            assert!(sbatch_options(&r).is_err());
        }
    }

    #[test]
    fn one_shard_is_an_array_of_one() {
        assert!(text(&slurm(&launch(1)), "array.sbatch").contains("--array=0-0\n"));
    }

    #[test]
    fn k8s_indexed_job_runs_one_shard_per_index() {
        let (shards, merge) = k8s_jobs(&launch(4), "reg/soig:1", "soig-data");
        assert_eq!(shards["apiVersion"], "batch/v1");
        let spec = &shards["spec"];
        assert_eq!(spec["completionMode"], "Indexed");
        assert_eq!(spec["completions"], 4);
        assert_eq!(spec["parallelism"], 4);
        let pod = &spec["template"]["spec"];
        assert_eq!(pod["restartPolicy"], "Never");
        assert_eq!(
            pod["volumes"][0]["persistentVolumeClaim"]["claimName"],
            "soig-data"
        );
        let c = &pod["containers"][0];
        assert_eq!(c["volumeMounts"][0]["mountPath"], MOUNT);
        let cmd: Vec<&str> = c["command"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        // Kubernetes passes each item as one argument: no shell quoting here.
        assert_eq!(
            cmd[cmd.len() - 4..],
            [
                "--shard",
                "auto/4",
                "--out",
                "/scratch/run s/q-shard-$(SHARD)-of-4"
            ]
        );
        assert_eq!(c["env"][0]["name"], "SHARD");
        let m = merge["spec"]["template"]["spec"]["containers"][0]["command"]
            .as_array()
            .unwrap();
        assert_eq!(m[1], "merge");
        assert_eq!(m[2], "/scratch/run s/q-shard-0-of-4");
        assert_eq!(m[5], "/scratch/run s/q-shard-3-of-4");
        assert_eq!(merge["metadata"]["name"], "soig-quick-start-merge");
    }

    #[test]
    fn k8s_submit_stops_on_a_failed_job() {
        let files = k8s(&launch(2), "reg/soig:1", "soig-data", 3600);
        let submit = text(&files, "submit.sh");
        assert!(submit.contains("deadline=${SOIG_K8S_DEADLINE_S:-3600}\n"));
        for f in ["shards.yaml", "merge.yaml"] {
            assert!(
                text(&files, f).contains("  activeDeadlineSeconds: 3600\n"),
                "{f}"
            );
        }
        // `kubectl wait --for=condition=complete` never returns for a Failed Job.
        assert!(!submit.contains("kubectl wait --for"), "{submit}");
        assert!(
            submit.contains("*\" Failed \"*) echo \"job $1 failed:\""),
            "{submit}"
        );
        assert!(submit.contains("finished soig-quick-start\n"), "{submit}");
        assert!(
            submit.contains("finished soig-quick-start-merge\n"),
            "{submit}"
        );
    }

    #[test]
    fn yaml_is_block_style_with_quoted_strings() {
        let v = json!({"a": 1, "b": ["x y", {"c": "yes", "d": [2]}], "e f": {}, "g": []});
        assert_eq!(
            yaml(&v),
            "a: 1\nb:\n  - \"x y\"\n  - c: \"yes\"\n    d:\n      - 2\n\"e f\": {}\ng: []\n"
        );
    }
}
