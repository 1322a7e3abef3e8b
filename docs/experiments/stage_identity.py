"""Run dvc.yaml stages' commands with the code of two commits on the data of a checkout, and
compare their outputs (docs/experiments/2026-11-29-studies-tools-params.md). Each run happens in a
scratch tree: the commit's files (git archive), every dep linked read-only from the checkout,
every out written fresh in the scratch tree. JSON is compared without its clock readings and
machine, Parquet by its table and its metadata without the scratch tree's path.

    python -m docs.experiments.stage_identity BEFORE_REV AFTER_REV STAGE [STAGE ...]
"""
import hashlib, json, os, tempfile, shutil, subprocess, sys, time
from pathlib import Path
from dvc.repo import Repo

MAIN = Path(__file__).resolve().parents[2]  # the checkout whose data the stages read
SCRATCH = Path(tempfile.gettempdir()) / 'stage_identity'


def tree(rev: str) -> Path:
    root = SCRATCH / rev
    if not root.exists():
        root.mkdir(parents=True)
        archive = subprocess.run(['git', '-C', str(MAIN), 'archive', rev], check=True, capture_output=True).stdout
        subprocess.run(['tar', '-x', '-C', str(root)], input=archive, check=True)
    return root


TIMING = ('seconds', 'elapsed', 'started', 'finished', 'timestamp', 'wall', 'machine', 'hostname')


def without_timing(node):
    """A JSON value with the clock readings and the machine left out (they differ run to run)."""
    if isinstance(node, dict):
        return {k: without_timing(v) for k, v in node.items() if not any(t in k for t in TIMING)}
    if isinstance(node, list):
        return [without_timing(v) for v in node]
    return node


def file_digest(p: Path) -> str:
    if p.suffix == '.parquet':
        import re
        import pyarrow as pa, pyarrow.parquet as pq
        table = pq.read_table(p)
        meta = {k: re.sub(re.escape(str(SCRATCH)).encode() + rb'/[^/]+/', b'<tree>/', v)
                for k, v in (table.schema.metadata or {}).items()}
        sink = pa.BufferOutputStream()
        with pa.ipc.new_stream(sink, table.schema.remove_metadata()) as writer:
            writer.write_table(table.replace_schema_metadata(None))
        return 'parquet:' + hashlib.md5(sink.getvalue().to_pybytes() + repr(sorted(meta.items())).encode()).hexdigest()
    if p.suffix == '.json':
        return 'json:' + hashlib.md5(json.dumps(without_timing(json.loads(p.read_text())), sort_keys=True).encode()).hexdigest()
    if p.suffix == '.csv' and 'seconds' in p.read_text().splitlines()[0]:
        import pandas as pd
        frame = pd.read_csv(p)
        return 'csv:' + hashlib.md5(frame.drop(columns=[c for c in frame if 'seconds' in c]).to_csv().encode()).hexdigest()
    return hashlib.md5(p.read_bytes()).hexdigest()


def digest(path: Path) -> dict[str, str]:
    if path.is_file():
        return {'': file_digest(path)}
    return {str(p.relative_to(path)): file_digest(p) for p in sorted(path.rglob('*')) if p.is_file()}


def run(stage, root: Path) -> tuple[dict, float, int]:
    for dep in stage.deps:
        rel = Path(dep.def_path)
        if rel.parts[0] in ('params.yaml',) or not (MAIN / rel).exists():
            continue
        target = root / rel
        if any(parent.is_symlink() for parent in target.parents if root in parent.parents):
            continue  # there already, through a linked folder: touching it would touch the checkout
        if target.is_symlink() or target.exists():
            if target.is_symlink() or rel.parts[0] in ('data', 'checkpoints', 'metrics', 'studies', 'reports'):
                if target.is_dir() and not target.is_symlink():
                    shutil.rmtree(target)
                elif target.exists() or target.is_symlink():
                    target.unlink()
            else:
                continue  # code in the tree itself
        target.parent.mkdir(parents=True, exist_ok=True)
        target.symlink_to(MAIN / rel)
    outs = [Path(o.def_path) for o in stage.outs]
    for out in outs:
        p = root / out
        linked = [a for a in p.parents if root in a.parents and a.is_symlink()]
        if linked:  # writing there would write into the checkout the link points at
            raise SystemExit(f"{stage.addressing}: its output {out} lies in {linked[0]}, a linked "
                             "input folder of another stage run in this scratch tree")
        if p.is_symlink():
            p.unlink()
        elif p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()
        p.parent.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, 'PYTHONPATH': str(root), 'PATH': f"{Path(sys.executable).parent}:{os.environ['PATH']}"}
    start = time.perf_counter()
    rc = subprocess.call(['nice', '-n', '5', 'bash', '-c', stage.cmd], cwd=root, env=env,
                         stdout=subprocess.DEVNULL, stderr=open(root / f'{stage.addressing.replace("/", "_")}.err', 'w'))
    return {str(o): digest(root / o) for o in outs if (root / o).exists()}, time.perf_counter() - start, rc


def main() -> int:
    before, after, *targets = sys.argv[1:]
    repo = Repo(str(MAIN))
    different = compared = 0
    for target in targets:
        (stage,) = repo.stage.collect(target)
        got = {}
        for rev in (before, after):
            got[rev] = run(stage, tree(rev))
        (a, ta, ra), (b, tb, rb) = got[before], got[after]
        files = sum(len(v) for v in a.values())
        same = a == b and ra == rb == 0 and files > 0
        compared += 1
        different += not same
        print(f'{stage.addressing}: rc {ra}/{rb}, {files} files, {"identical" if same else "DIFFERENT"} '
              f'({ta:.0f} s / {tb:.0f} s)', flush=True)
        if not same:
            for out in set(a) | set(b):
                if a.get(out) != b.get(out):
                    print(f'   {out}: {len(a.get(out, {}))} vs {len(b.get(out, {}))} files', flush=True)
    print(f'stages compared: {compared}, different: {different}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
