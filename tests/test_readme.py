"""The README's Python snippets run, and its YAML model loads and matches the Python one."""
import re
from pathlib import Path

import numpy as np
import yaml

README = Path(__file__).resolve().parents[1] / "README.md"


def blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", README.read_text(), flags=re.S)


def test_python_snippets_run():
    namespace = {}
    for code in blocks("python"):
        exec(compile(code, str(README), "exec"), namespace)
    assert namespace["res"].success
    assert np.isfinite(namespace["slider_x"]).all()


def test_yaml_snippet_is_the_same_model():
    from spatialmbd.io import load_model
    (yaml_text,) = blocks("yaml")
    model, analysis = load_model(yaml.safe_load(yaml_text))
    assert analysis.method == "baumgarte" and analysis.t_end == 10.0
    assert model.body_names == ("link",)
    assert np.allclose(model.q0, [[0, 0.5, 0, 1, 0, 0, 0]])
