"""`make blender-addon`: the Blender extension (pipelines/blender/pcsss_addon/)
packaged as Blender 4.2+ installs it, a zip with its manifest, its
modules, and the pcsss wheel the manifest's `wheels` names.

Usage: python addon_package.py WHEEL OUT.zip
"""

import pathlib
import sys
import zipfile

HERE = pathlib.Path(__file__).resolve().parent / "pcsss_addon"


def main():
    wheel, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    if not wheel.is_file():
        sys.exit(f"addon_package: {wheel}: no such wheel (make pywheel)")
    # The `wheels` key goes before the first table.
    head, sep, tail = (HERE / "blender_manifest.toml").read_text().partition("\n[permissions]")
    manifest = head.rstrip("\n") + f'\nwheels = ["./wheels/{wheel.name}"]\n' + sep + tail
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".zip.tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("blender_manifest.toml", manifest)
        for f in sorted(HERE.glob("*.py")):
            z.write(f, f.name)
        z.write(wheel, f"wheels/{wheel.name}")
    tmp.replace(out)
    print(f"addon_package: {out}")


if __name__ == "__main__":
    main()
