"""Import an MJCF file, simulate it, save it as a model file and animate it.

    pip install 'spatialmbd[mjcf]'
    python examples/mjcf/import_four_bar.py [OUT_DIR]

The RSSR four-bar of four_bar.xml is closed by an MJCF ``connect`` equality, which becomes an
exact spherical joint here. Writes four_bar_rssr.yaml (the imported model) and
four_bar_rssr.html (an offline WebGL animation with the joint reaction forces as arrows).
"""
from __future__ import annotations

import pathlib
import sys

from spatialmbd.animation import write_animation
from spatialmbd.importers import read_mjcf
from spatialmbd.io.modelfile import save_model
from spatialmbd.simulate import simulate

HERE = pathlib.Path(__file__).resolve().parent


def main(out_dir=".", t_end: float = 2.0) -> dict:
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    imported = read_mjcf(HERE / "four_bar.xml")
    for body, ids in imported.groups.items():
        print(f"body {body:8s} <- MuJoCo bodies {ids}")
    model = imported.builder.compile()
    results = simulate(model, t_end, output_step=t_end / 200, rtol=1e-8, atol=1e-10)
    print(f"{results.status}: {len(results.t)} outputs up to t = {results.t[-1]:.3f} s")
    yaml_path = save_model(imported.builder, out_dir / f"{model.name}.yaml")
    html_path = write_animation(results, out_dir / f"{model.name}.html", reactions=True)
    print(f"wrote {yaml_path} and {html_path}")
    return {"results": results, "yaml": yaml_path, "html": html_path}


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else ".")
