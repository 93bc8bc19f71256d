"""Builds the Blender extension: blender/dist/mdg_grammars-VERSION.zip.

    python blender/build.py [--profile release|dev] [--maturin PATH]

Builds the `mdg` wheel with maturin (python/), then packs mdg_grammars/ with the wheel
under wheels/ and the manifest's `wheels` entry naming it, as Blender's extension
format wants. Install the .zip with Edit → Preferences → Get Extensions → Install
from Disk (or `blender --command extension install-file -r user_default FILE`).
Prints the path of the .zip.
"""

import argparse
import pathlib
import shutil
import subprocess
import sys
import tempfile
import zipfile

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--profile", default="release", help="cargo profile of the wheel (release, dev)")
    ap.add_argument("--maturin", default=shutil.which("maturin") or "maturin", help="the maturin command")
    ap.add_argument("--out", default=str(HERE / "dist"), help="where the .zip goes")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [args.maturin, "build", "--quiet", "-m", str(ROOT / "python" / "Cargo.toml"), "-o", tmp]
        cmd += ["--release"] if args.profile == "release" else ["--profile", args.profile]
        r = subprocess.run(cmd)
        if r.returncode != 0:
            sys.exit(f"build.py: maturin failed ({r.returncode})")
        wheels = sorted(pathlib.Path(tmp).glob("mdg-*.whl"))
        if len(wheels) != 1:
            sys.exit(f"build.py: expected one wheel from maturin, found {[w.name for w in wheels]}")
        wheel = wheels[0]
        src = HERE / "mdg_grammars"
        manifest = (src / "blender_manifest.toml").read_text()
        version = next(l.split('"')[1] for l in manifest.splitlines() if l.startswith("version"))
        manifest = manifest.replace("\n[permissions]", f'\nwheels = ["./wheels/{wheel.name}"]\n\n[permissions]', 1)
        out = pathlib.Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        zip_path = out / f"mdg_grammars-{version}.zip"
        with zipfile.ZipFile(zip_path, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("blender_manifest.toml", manifest)
            for f in sorted(src.glob("*.py")):
                z.write(f, f.name)
            z.write(wheel, f"wheels/{wheel.name}")
    print(zip_path)


if __name__ == "__main__":
    main()
