"""What decoding Basis Universal textures adds to a scene's load (HM3D's and Habitat's .basis.glb): ms per
megapixel of texture, transcoded to RGB, stored as a PPM and read back by PIL as trimesh reads it, for the Basis
images in tests/data/basis/ (KTX 2 and .basis, ETC1S) and any given with --image; --scan times load_scene of a
.basis.glb and the share of it that decoding its textures takes."""
from __future__ import annotations

import argparse
import io
import timeit
from pathlib import Path

import numpy as np
from PIL import Image

from rvn_data.scenes.basis_textures import _ppm, transcode

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "basis"


def decode(blob: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(_ppm(transcode(blob, "benchmark")))).convert("RGB"))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--image", type=Path, nargs="*", default=[], help="more .ktx2 / .basis files")
    ap.add_argument("--scan", type=Path, help="a .basis.glb to load with and without its textures")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    for path in sorted(DATA.glob("*.ktx2")) + sorted(DATA.glob("*.basis")) + list(args.image):
        blob = path.read_bytes()
        rgb = decode(blob)
        best = min(timeit.repeat(lambda: decode(blob), number=1, repeat=args.repeats))
        mp = rgb.shape[0] * rgb.shape[1] / 1e6
        print(f"{path.name}: {rgb.shape[1]}x{rgb.shape[0]}, {best * 1e3:.1f} ms = {best * 1e3 / mp:.1f} ms per "
              f"megapixel (transcode, PPM, PIL)")
    if args.scan:
        from rvn_data.scenes import load_scene
        from rvn_data.scenes.basis_textures import decoded_gltf

        whole = min(timeit.repeat(lambda: load_scene(args.scan), number=1, repeat=args.repeats))
        textures = min(timeit.repeat(lambda: decoded_gltf(args.scan), number=1, repeat=args.repeats))
        print(f"{args.scan.name}: load_scene {whole * 1e3:.1f} ms, of which decoding its Basis textures "
              f"{textures * 1e3:.1f} ms ({textures / whole:.0%})")

if __name__ == "__main__":
    main()
