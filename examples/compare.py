# %% [markdown]
# # Three integrators on the Cornell box, at equal time
#
# `compare.ipynb` and `compare.py` in `examples/` hold the same cells (a test keeps them
# alike): open the notebook in Jupyter, or run the script whole, as CI does. It loads the
# Cornell box, renders it with three integrators for the same time, plots each image beside
# its error against a reference, then sweeps a parameter and plots how the error falls with
# time.
#
# After `pip install .`; figures go to `out/python-example/` under the repository, or to the
# folder `RAYLAB_EXAMPLE_OUT` names.

# %%
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import raylab

try:
    root = Path(__file__).resolve().parent.parent
except NameError:  # in a notebook, run from examples/ or the repository's root
    root = Path.cwd().parent if Path.cwd().name == "examples" else Path.cwd()
out = Path(os.environ.get("RAYLAB_EXAMPLE_OUT", root / "out" / "python-example"))
out.mkdir(parents=True, exist_ok=True)
# Small and quick, so that CI runs it; raise both for a real study.
size, seconds = (128, 128), 1.0

scene = raylab.load(root / "scenes" / "cornell_box.ron")
print(scene, "materials:", scene.materials)

# %% [markdown]
# ## A reference, and three integrators at equal time

# %%
reference = scene.render("path", spp=1024, size=size, seed=1000)
contestants = ["path", "bdpt", "lighttracer"]
images = {name: scene.render(name, time=seconds, size=size) for name in contestants}


def mse(image):
    return float(np.mean((image - reference) ** 2))


fig, axes = plt.subplots(2, len(contestants), figsize=(3 * len(contestants), 6))
for column, (name, image) in enumerate(images.items()):
    axes[0, column].imshow(np.clip(image, 0, 1) ** (1 / 2.2))
    axes[0, column].set_title(f"{name}: MSE {mse(image):.2e}")
    error = np.abs(image - reference).mean(axis=2)
    axes[1, column].imshow(error, cmap="magma", vmin=0, vmax=0.2)
    axes[1, column].set_title("|error|")
for ax in axes.flat:
    ax.axis("off")
fig.tight_layout()
fig.savefig(out / "equal_time.png", dpi=80)

# %% [markdown]
# ## The command line's statistics, as a DataFrame
#
# `raylab.compare` runs `raylab compare`: several runs per integrator, 95% intervals, bias
# and convergence slopes.

# %%
result = raylab.compare(
    scene,
    contestants,
    time=seconds / 2,
    runs=2,
    reference={"spp": 1024},
    size=size,
    out=out / "compare",
)
table = result.to_pandas()[["spp", "time", "mse", "mse_ci95", "relmse", "bias2", "slope"]]
print(table.to_string())

# %% [markdown]
# ## A sweep: Russian roulette's start depth, and how the error falls with time

# %%
sweep = raylab.compare(
    scene,
    ["russian-roulette"],
    sweep=("rr-depth", [1, 3, 6]),
    spp=32,
    reference={"spp": 1024},
    size=size,
    out=out / "sweep",
)
curves = sweep.convergence()
fig, ax = plt.subplots(figsize=(5, 4))
for label, curve in curves.groupby("label"):
    ax.loglog(curve["time"], curve["mse"], marker="o", label=label)
ax.set_xlabel("time (s)")
ax.set_ylabel("MSE")
ax.legend()
fig.tight_layout()
fig.savefig(out / "convergence.png", dpi=80)

# %% [markdown]
# ## An edit, without reloading: a redder wall

# %%
scene.set_material("red", albedo=(0.9, 0.05, 0.05))
redder = scene.render("path", spp=16, size=size)
raylab.write(out / "redder.png", redder)
print("wrote", *sorted(p.name for p in out.iterdir()))
