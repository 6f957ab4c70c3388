"""Draw a few instances of every part family into docs/media/families.png (README).

Each column is a family, each row a seed; every panel has the same scale (the cell's limit on
the bounding-sphere radius is 0.189 m), so sizes compare across the picture.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from vprobot.families import FAMILIES

OUT = Path(__file__).resolve().parent.parent / "docs" / "media" / "families.png"
HALF_SIDE_M = 0.15
"""Half the side of every panel's cube."""
_LIGHT = np.array([0.4, -0.5, 0.8]) / np.linalg.norm([0.4, -0.5, 0.8])
_STEEL = np.array([0.55, 0.62, 0.72])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4, help="instances per family")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    names = list(FAMILIES)
    figure = plt.figure(figsize=(1.5 * len(names), 1.5 * args.seeds))
    for column, name in enumerate(names):
        for row in range(args.seeds):
            mesh = FAMILIES[name].instance(row).mesh
            ax = figure.add_subplot(args.seeds, len(names), row * len(names) + column + 1,
                                    projection="3d")
            # Lambert shading by hand: matplotlib's own shading ignores a mesh's normals.
            light = 0.35 + 0.65 * np.clip(mesh.face_normals @ _LIGHT, 0, 1)
            colors = light[:, None] * _STEEL
            # Edges in the face colour hide the seams antialiasing leaves between triangles.
            ax.add_collection3d(Poly3DCollection(mesh.triangles, facecolors=colors,
                                                 edgecolors=colors, linewidths=0.2))
            for axis in "xyz":
                getattr(ax, f"set_{axis}lim")(-HALF_SIDE_M, HALF_SIDE_M)
            ax.set_box_aspect((1, 1, 1), zoom=1.9)
            ax.view_init(elev=28, azim=-55)
            ax.set_axis_off()
            if row == 0:
                ax.set_title(name, fontsize=10)
    figure.subplots_adjust(left=0, right=1, bottom=0, top=0.94, wspace=0, hspace=0)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=80)
    print(f"wrote {args.out} ({args.out.stat().st_size // 1024} KB)")


if __name__ == "__main__":
    main()
