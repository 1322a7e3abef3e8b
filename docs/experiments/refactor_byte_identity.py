"""Re-run chosen stages with two versions of the code on the same inputs and compare the outputs
(docs/experiments/2026-11-28-floors-byte-identity.md): each stage's command from dvc.lock, with one
tree's code, on the inputs of a checkout that holds them (DATA_TREE), into a scratch folder; the
commands run with this interpreter's environment.

    python refactor_byte_identity.py run CODE_TREE DATA_TREE SCRATCH
    python refactor_byte_identity.py compare SCRATCH_A SCRATCH_B
"""
import hashlib, json, os, subprocess, sys, time
from pathlib import Path
import yaml

LOCK_FILE = Path(__file__).resolve().parents[2] / "dvc.lock"  # the commands, as DVC resolves them
STAGES = ["windows", "semantic_maps", "train_baseline@sgan-60", "evaluate_baseline@sgan-60",
          "fit_model@constant_velocity-60", "predict_model@constant_velocity-60",
          "short_term_windows", "train_short_term_baseline@eth-sgan",
          "evaluate_short_term_baseline@eth-sgan", "train_ynet", "evaluate_ynet"]
TINY = {"ynet": {"cpu": {"epochs": 1, "steps_per_epoch": 40}},
        "eval": {"cpu": {"rounds": 1, "ablation_rounds": 1, "ka_grid_k_e": [20], "ka_grid_k_a": [1, 2]}}}


def deep_update(d, u):
    for k, v in u.items():
        if isinstance(v, dict):
            deep_update(d[k], v)
        else:
            d[k] = v


def lock():
    return yaml.safe_load(LOCK_FILE.read_text())["stages"]


def run(code_tree: Path, data_tree: Path, scratch: Path):
    LOCK = lock()
    scratch.mkdir(parents=True)
    for name in ("pipeline", "ynet", "manifests", "tools"):
        (scratch / name).symlink_to(code_tree / name)
    params = yaml.safe_load(open(code_tree / "params.yaml"))
    deep_update(params, TINY)
    (scratch / "params.yaml").write_text(yaml.safe_dump(params))
    made = set()
    for stage in STAGES:
        entry = LOCK[stage]
        for dep in entry["deps"]:
            path = dep["path"]
            if path.startswith("data/code_fingerprints") or path in made or path.startswith("manifests"):
                continue
            target, link = data_tree / path, scratch / path
            if not link.exists():
                link.parent.mkdir(parents=True, exist_ok=True)
                link.symlink_to(target)
        for out in entry.get("outs", []):
            (scratch / out["path"]).parent.mkdir(parents=True, exist_ok=True)
            made.add(out["path"])
        start = time.time()
        env = dict(os.environ, PATH=str(Path(sys.executable).parent) + os.pathsep + os.environ["PATH"])
        result = subprocess.run(entry["cmd"], shell=True, cwd=scratch, capture_output=True, text=True, env=env)
        print(f"{stage}: rc {result.returncode}, {time.time() - start:.0f} s", flush=True)
        if result.returncode:
            print(result.stderr[-3000:]); sys.exit(1)


TIMING = ("seconds", "time", "started", "elapsed", "duration", "device")


def clean(value):
    if isinstance(value, dict):
        return {k: clean(v) for k, v in value.items() if not any(t in k for t in TIMING)}
    if isinstance(value, list):
        return [clean(v) for v in value]
    return value


def digest(path: Path):
    if path.suffix == ".json":
        return hashlib.md5(json.dumps(clean(json.loads(path.read_text())), sort_keys=True).encode()).hexdigest()
    if path.suffix == ".pt":
        import torch
        obj = torch.load(path, map_location="cpu", weights_only=False)
        def walk(o):
            if isinstance(o, torch.Tensor): return o.numpy().tobytes()
            if isinstance(o, dict): return b"".join(str(k).encode() + walk(v) for k, v in sorted(o.items(), key=lambda kv: str(kv[0])) if not any(t in str(k) for t in TIMING))
            if isinstance(o, (list, tuple)): return b"".join(walk(v) for v in o)
            return repr(o).encode()
        return hashlib.md5(walk(obj)).hexdigest()
    return hashlib.md5(path.read_bytes()).hexdigest()


def files(scratch: Path):
    LOCK = lock()
    out = {}
    for stage in STAGES:
        for o in LOCK[stage].get("outs", []):
            p = scratch / o["path"]
            for f in ([p] if p.is_file() else sorted(x for x in p.rglob("*") if x.is_file())):
                out[str(f.relative_to(scratch))] = f
    return out


def compare(a: Path, b: Path):
    fa, fb = files(a), files(b)
    same = differ = 0
    for key in sorted(set(fa) | set(fb)):
        if key not in fa or key not in fb:
            print("ONLY ONE SIDE", key); differ += 1; continue
        if digest(fa[key]) == digest(fb[key]):
            same += 1
        else:
            print("DIFFERS", key); differ += 1
    print(f"{same} files identical (timing fields aside), {differ} differ")


if __name__ == "__main__":
    if sys.argv[1] == "run":
        run(Path(sys.argv[2]), Path(sys.argv[3]), Path(sys.argv[4]))
    else:
        compare(Path(sys.argv[2]), Path(sys.argv[3]))
