//! Batch engines (issue 20, part): `synthcam dataset --shard auto` under a Slurm job array and a
//! Kubernetes Indexed Job, run exactly as `docs/batch/` writes them (without a controller: the
//! variables each engine sets are set here), give byte-identical images to the unsharded run.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{bin, images};

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("synthcam-batch-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("tmp");
    d
}

/// A 16-image copy of the tiny spec.
fn spec(dir: &Path) -> PathBuf {
    let p = dir.join("spec.toml");
    std::fs::write(&p, include_str!("../../assets/specs/tiny.toml").replace("count = 200", "count = 16")).expect("spec");
    p
}

fn check(o: &std::process::Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The unsharded run and a merge of `dir`, compared image by image.
fn same_as_unsharded(root: &Path, spec: &Path, dir: &Path) {
    let one = root.join("one");
    check(&Command::new(bin()).arg("dataset").arg(spec).arg("-o").arg(&one).output().expect("run"));
    check(&Command::new(bin()).args(["dataset", "merge"]).arg(dir).output().expect("merge"));
    let (a, b) = (images(&one), images(dir));
    assert_eq!(a.len(), 32);
    assert_eq!(a, b, "the batch run differs from the unsharded run");
    assert_eq!(std::fs::read(one.join("manifest.jsonl")).unwrap(), std::fs::read(dir.join("manifest.jsonl")).unwrap());
}

#[test]
fn slurm_array_script_shards_like_the_unsharded_run() {
    let root = tmp("slurm");
    let spec = spec(&root);
    let out = root.join("array");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/batch/dataset-array.sbatch");
    let text = std::fs::read_to_string(&script).unwrap();
    assert!(text.contains("#SBATCH --array=0-3"), "the script's array");
    // Slurm runs the script once per task with these variables; the array here starts at 1 to
    // check the offset (`--array=1-4`).
    let path = format!("{}:{}", Path::new(bin()).parent().unwrap().display(), std::env::var("PATH").unwrap_or_default());
    for task in 1..=4 {
        let o = Command::new("bash")
            .arg(&script)
            .env("PATH", &path)
            .env("SPEC", &spec)
            .env("OUT", &out)
            .env("SLURM_ARRAY_TASK_ID", task.to_string())
            .env("SLURM_ARRAY_TASK_MIN", "1")
            .env("SLURM_ARRAY_TASK_COUNT", "4")
            .env("SLURM_CPUS_PER_TASK", "1")
            .output()
            .expect("bash");
        check(&o);
    }
    same_as_unsharded(&root, &spec, &out);
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn kubernetes_indexed_job_contract_shards_like_the_unsharded_run() {
    let root = tmp("k8s");
    let spec = spec(&root);
    let out = root.join("job");
    let manifest = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/batch/dataset-indexed-job.yaml")).unwrap();
    let completions: u32 = manifest.lines().find_map(|l| l.trim().strip_prefix("completions:")).expect("completions").trim().parse().unwrap();
    assert!(manifest.contains(&format!("- name: JOB_COMPLETIONS\n              value: \"{completions}\"")), "JOB_COMPLETIONS equals completions");
    assert!(manifest.contains(r#""--shard", "auto"]"#));
    for index in 0..completions {
        let o = Command::new(bin())
            .arg("dataset")
            .arg(&spec)
            .arg("-o")
            .arg(&out)
            .args(["--shard", "auto"])
            .env("JOB_COMPLETION_INDEX", index.to_string())
            .env("JOB_COMPLETIONS", completions.to_string())
            .output()
            .expect("run");
        check(&o);
    }
    same_as_unsharded(&root, &spec, &out);
    // Without an engine's variables `auto` is a clear error.
    let o = Command::new(bin())
        .arg("dataset")
        .arg(&spec)
        .arg("-o")
        .arg(root.join("none"))
        .args(["--shard", "auto"])
        .env_remove("JOB_COMPLETION_INDEX")
        .env_remove("SLURM_ARRAY_TASK_ID")
        .output()
        .expect("run");
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("SLURM_ARRAY_TASK_ID"));
    let _ = std::fs::remove_dir_all(&root);
}

/// Issue 20: the sbatch script as a real 4-task job array on a single-node Slurm cluster
/// (`.ci/slurm-local.sh`, started by `.ci/run`, which sets `SYNTHCAM_SLURM=1`): merged, it equals
/// the unsharded run byte for byte.
#[test]
fn slurm_job_array_on_a_local_cluster_matches_the_unsharded_run() {
    if std::env::var("SYNTHCAM_SLURM").as_deref() != Ok("1") {
        eprintln!("skipped: no local Slurm cluster (run .ci/slurm-local.sh as root and set SYNTHCAM_SLURM=1)");
        return;
    }
    let root = tmp("sbatch");
    let spec = spec(&root);
    let out = root.join("array");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/batch/dataset-array.sbatch");
    let path = format!("{}:{}", Path::new(bin()).parent().unwrap().display(), std::env::var("PATH").unwrap_or_default());
    let t0 = std::time::Instant::now();
    let o = Command::new("sbatch")
        .arg("--wait")
        .arg(format!("--export=ALL,SPEC={},OUT={},PATH={path}", spec.display(), out.display()))
        .arg(format!("--output={}/slurm-%a.out", root.display()))
        .arg(&script)
        .output()
        .expect("sbatch");
    let logs: String = (0..4).map(|a| std::fs::read_to_string(root.join(format!("slurm-{a}.out"))).unwrap_or_default()).collect();
    assert!(o.status.success(), "sbatch: {}\n{}\n{logs}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    eprintln!("4-task Slurm array, 16 images: {:.1} s wall (submit to last task done)", t0.elapsed().as_secs_f64());
    same_as_unsharded(&root, &spec, &out);
    let _ = std::fs::remove_dir_all(&root);
}
