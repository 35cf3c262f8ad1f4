"""raylab from Python: scenes kept loaded, renders as numpy arrays, edits without reloading.

Everything here runs raylab's own engine, the code the ``raylab`` command runs: the same
importers (RON, Mitsuba 3 XML, pbrt-v4), the same render job (a render here is bit-identical
to ``raylab render`` with the same settings), the same incremental edits ``render --watch``
makes, and the same image files.

    >>> import raylab
    >>> scene = raylab.load("scenes/cornell_box.ron")
    >>> image = scene.render("path", spp=16, size=(128, 128))     # (128, 128, 3) float32
    >>> scene.set_material("red", albedo=(0.9, 0.1, 0.1))          # no reload, no BVH rebuild
    >>> image, variance = scene.render("bdpt", spp=16, variance=True)
    >>> raylab.write("cornell.exr", image, variance=variance)

Errors of the engine raise :class:`RaylabError` with the message the command line prints
(the file, line and column, or the entity). Ctrl-C stops a render at the end of the pass in
progress and raises ``KeyboardInterrupt``; the interpreter lock is released while a scene
loads or renders, so other Python threads keep running.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import RaylabError, __version__

__all__ = [
    "Comparison",
    "RaylabError",
    "Scene",
    "compare",
    "integrators",
    "load",
    "read",
    "write",
    "__version__",
]

PathLike = Union[str, Path]


def integrators() -> list:
    """The integrator registry, as ``raylab integrators`` lists it.

    A list of dicts, one per integrator: ``name``, ``summary``, ``media`` (``"none"``,
    ``"scattering"`` or ``"all"``: which participating media it renders) and ``params``, each
    a dict of ``name``, ``kind`` (``int``, ``float``, ``depth``), ``default`` (``inf`` for an
    unlimited depth), ``min``, ``max`` and ``doc``.
    """
    return _native.integrators()


def load(
    path: PathLike,
    *,
    approximate: bool = False,
    search: Sequence[PathLike] = (),
    allow: Sequence[PathLike] = (),
    **defines: Any,
) -> "Scene":
    """Loads a scene (RON, Mitsuba 3 XML, pbrt-v4) as ``raylab render`` does.

    ``defines`` set a Mitsuba scene's ``<default>`` parameters, as ``-D NAME=VALUE``:
    ``raylab.load("scene.xml", spp=64, integrator="path")``. ``approximate`` is
    ``--approximate`` (replace what raylab lacks by the nearest thing, with a warning),
    ``search`` the folders of ``-a DIR``, ``allow`` those of ``--allow-path``. The scene's
    warnings are in :attr:`Scene.warnings`.
    """
    native = _native.load(
        Path(path),
        defines=[(name, _text(value)) for name, value in defines.items()],
        approximate=approximate,
        search=[Path(p) for p in search],
        allow=[Path(p) for p in allow],
    )
    return Scene(native)


def read(path: PathLike, *, variance: bool = False):
    """The image of an EXR (or PNG, HDR) file as a float32 array of shape (H, W, 3).

    With ``variance=True``, a pair: the image and its per-pixel variance layer (``None``
    when the file has none), as ``raylab render`` writes them into its EXRs.
    """
    image, var = _native.read(Path(path))
    return (image, var) if variance else image


def write(
    path: PathLike,
    image,
    *,
    variance=None,
    exposure: float = 0.0,
    tonemap: str = "clamp",
) -> None:
    """Writes ``image`` ((H, W, 3) linear radiance) as EXR or PNG, by the file's extension.

    As ``raylab render`` writes its output: an EXR linear in float32 (with ``variance`` as its
    variance layer when given), a PNG through ``exposure`` (in stops) and ``tonemap``
    (``clamp``, ``aces``, ``reinhard``) into sRGB.
    """
    image = _rgb_array(image, "image")
    if variance is not None:
        variance = _rgb_array(variance, "variance")
    _native.write(Path(path), image, variance, float(exposure), tonemap)


class Scene:
    """A loaded scene: render it, edit it, render again.

    Made by :func:`load`. Edits (:meth:`set_material`, :meth:`move`, :meth:`set_emitter`)
    change the scene in memory through the incremental path ``raylab render --watch`` takes:
    a material's parameter rebuilds nothing but the material, a moved entity the top of the
    BVH, an emitter the light table. A scene reached by edits renders the bits the same scene
    loaded fresh from a file renders.
    """

    def __init__(self, native: "_native.Scene"):
        self._native = native
        #: What the last :meth:`render` cost: ``spp``, ``elapsed`` (seconds), ``samples``,
        #: ``rays``, ``threads``, ``time_budget_spent``.
        self.last_stats: Optional[dict] = None

    @property
    def path(self) -> Path:
        """The scene file."""
        return self._native.path

    @property
    def warnings(self) -> list:
        """What the load noted (approximations, unused meshes, ...)."""
        return self._native.warnings

    @property
    def size(self) -> Tuple[int, int]:
        """The camera's image size, ``(width, height)``."""
        return self._native.size

    @property
    def defaults(self) -> dict:
        """The scene's own ``integrator``, ``spp`` and ``seed`` (its ``render`` block)."""
        return self._native.defaults

    @property
    def materials(self) -> list:
        """The names of the materials, in file order."""
        return self._native.materials

    @property
    def entities(self) -> list:
        """The names of the named entities, in file order."""
        return self._native.entities

    def render(
        self,
        integrator: Optional[str] = None,
        *,
        spp: Optional[int] = None,
        time: Optional[float] = None,
        seed: Optional[int] = None,
        size: Optional[Tuple[int, int]] = None,
        threads: Optional[int] = None,
        params: Optional[Mapping[str, Any]] = None,
        sampler: Optional[str] = None,
        spectral: Optional[bool] = None,
        variance: bool = False,
        callback: Optional[Callable[[dict], Any]] = None,
    ):
        """Renders the scene; returns linear radiance as float32 of shape (H, W, 3).

        The arguments are ``raylab render``'s flags, and the result is bit-identical to its
        EXR at the same settings: ``integrator`` (default: the scene's), ``spp`` (default:
        the scene's, or open-ended with ``time``), ``time`` (a budget in seconds), ``seed``
        (default: the scene's), ``size`` ``(width, height)``, ``threads`` (default: every
        core; the image does not depend on it), ``params`` (``{"max-depth": 8}``, as ``-p``),
        ``sampler`` (``"independent"``, ``"stratified"``, ``"sobol"``, ``"zsobol"`` or
        ``"halton"``; default: the scene's), ``spectral`` (``True``: sampled wavelengths, as
        ``--spectral``; ``False``: RGB; default: the scene's ``render.spectral``).

        With ``variance=True`` returns ``(image, variance)``: the per-pixel variance of the
        mean, or ``None`` for a 1-spp render. ``callback(info)`` is called after each pass
        with ``spp``, ``target``, ``elapsed`` and ``samples``; an exception it raises stops
        the render and propagates. The scene is busy while it renders: the callback, or
        another thread, may not read or edit it meanwhile (that raises ``RuntimeError``).
        Statistics land in :attr:`last_stats`.
        """
        pairs = [(name, _text(value)) for name, value in (params or {}).items()]
        (image, var), stats = self._native._render(
            integrator=integrator,
            spp=spp,
            time=time,
            seed=seed,
            size=tuple(size) if size is not None else None,
            threads=threads,
            params=pairs,
            sampler=sampler,
            spectral=spectral,
            callback=callback,
        )
        self.last_stats = stats
        return (image, var) if variance else image

    def set_material(self, name: str, **fields: Any) -> None:
        """Sets fields of material ``name``, as its RON description names them.

        ``scene.set_material("red", albedo=(0.9, 0.1, 0.1))``; ``scene.set_material("metal",
        roughness=0.2)``. The other fields keep their values; a field the material does not
        have raises ``ValueError`` naming it.
        """
        self._native._set_material(name, _json(fields))

    def move(
        self,
        entity: str,
        *,
        translate: Optional[Sequence[float]] = None,
        rotate: Optional[Sequence[float]] = None,
        scale: Optional[Sequence[float]] = None,
        matrix: Optional[Sequence[float]] = None,
    ) -> None:
        """Sets parts of entity ``entity``'s transform: ``translate``, ``rotate`` (Euler
        degrees about x, y, z) and ``scale``, the parts not given keeping their values; or a
        row-major 3x4 ``matrix``, alone, which replaces them. An entity placed by a matrix
        (as imported Mitsuba and pbrt scenes place theirs) moves by ``matrix`` only."""
        given = {"translate": translate, "rotate": rotate, "scale": scale, "matrix": matrix}
        self._native._set_transform(
            entity, _json({k: v for k, v in given.items() if v is not None})
        )

    def set_emitter(self, entity: str, **fields: Any) -> None:
        """Sets fields of entity ``entity``'s emitter: ``scene.set_emitter("light",
        radiance=(20, 20, 20))``."""
        self._native._set_emitter(entity, _json(fields))

    def to_ron(self) -> str:
        """The scene as it stands, edits included, as a RON scene file's text."""
        return self._native.to_ron()

    def __repr__(self) -> str:
        w, h = self.size
        return f"<raylab.Scene {self.path} {w}x{h}>"


def compare(
    scene: Union["Scene", PathLike],
    contestants: Union[Sequence[str], Mapping[str, Mapping[str, Any]]],
    *,
    reference: Union[None, PathLike, Mapping[str, Any]] = None,
    runs: int = 1,
    spp: Optional[int] = None,
    time: Optional[float] = None,
    seed: int = 0,
    size: Optional[Tuple[int, int]] = None,
    threads: Optional[int] = None,
    sweep: Optional[Tuple[str, Sequence[Any]]] = None,
    region: Optional[Tuple[int, int, int, int]] = None,
    target_error: Optional[float] = None,
    note: Optional[str] = None,
    spectral: bool = False,
    out: Optional[PathLike] = None,
) -> "Comparison":
    """Compares integrators on a scene, as ``raylab compare`` does; returns a :class:`Comparison`.

    ``scene`` is a :class:`Scene` (as it stands, edits included) or a scene file.
    ``contestants`` are integrator names (``["path", "bdpt"]``) or a dict of names to their
    parameters (``{"path": {}, "bdpt": {"max-depth": 8}}``); a name may carry its own sampler
    (``"path@sobol"``), and parameters may be names (``{"path": {"light-selection": "bvh"}}``).
    Each renders ``runs`` times with
    its own seed under the same budget: ``spp`` samples per pixel (default 16) or ``time``
    seconds each.

    ``reference`` is an EXR file, or a render described by a dict of ``integrator`` (default
    ``"path"``), ``params``, and ``spp`` (default 1024) or ``time``; by default ``path`` at
    1024 spp. A rendered reference is cached as the command line caches it. ``sweep`` is a
    parameter and its values (``("max-depth", [1, 2, 4])``; ``("sampler", ["independent",
    "sobol"])`` sweeps the sampler), ``region`` a rectangle ``(x, y,
    w, h)`` measured on its own, ``target_error`` the MSE whose time to reach is reported,
    ``spectral`` renders every image (the reference too) with sampled wavelengths.

    Everything the command writes (the page, images, ``metrics.json``) goes into ``out``,
    a temporary folder when not given.
    """
    if not isinstance(scene, Scene):
        scene = load(scene)
    if out is None:
        import tempfile

        out = tempfile.mkdtemp(prefix="raylab-compare-")
    out = Path(out)
    if isinstance(contestants, str):
        raise TypeError("contestants: give a list of integrator names, not one string")
    named = (
        {name: dict(p or {}) for name, p in contestants.items()}
        if isinstance(contestants, Mapping)
        else {name: {} for name in contestants}
    )
    args = [str(scene.path)]
    for name, params in named.items():
        args += ["-i", name]
        for key, value in params.items():
            args += ["-p", f"{name}.{key}={_text(value)}"]
    if isinstance(reference, Mapping):
        unknown = set(reference) - {"integrator", "params", "spp", "time"}
        if unknown:
            raise ValueError(f"reference: unknown keys {sorted(unknown)}")
        args += ["--reference-integrator", str(reference.get("integrator", "path"))]
        for key, value in (reference.get("params") or {}).items():
            args += ["-p", f"reference.{key}={_text(value)}"]
        if reference.get("spp") is not None:
            args += ["--reference-spp", str(reference["spp"])]
        if reference.get("time") is not None:
            args += ["--reference-time", repr(float(reference["time"]))]
    elif reference is not None:
        args += ["--reference", str(reference)]
    flags = {
        "--runs": runs,
        "--spp": spp,
        "--time": None if time is None else repr(float(time)),
        "--seed": seed,
        "--size": None if size is None else f"{size[0]}x{size[1]}",
        "--threads": threads,
        "--region": None if region is None else ",".join(str(v) for v in region),
        "--target-error": None if target_error is None else repr(float(target_error)),
        "--note": note,
    }
    for flag, value in flags.items():
        if value is not None:
            args += [flag, str(value)]
    if spectral:
        args.append("--spectral")
    if sweep is not None:
        key, values = sweep
        args += ["--sweep", f"{key}=" + ",".join(_text(v) for v in values)]
    args += ["-o", str(out), "--quiet"]
    report = json.loads(scene._native._compare(args))
    return Comparison(report, out)


class Comparison:
    """The result of :func:`compare`: the figures of ``metrics.json`` and the images.

    ``rows`` holds one dict per contestant with the command's figures (``mse`` and its 95%
    interval ``mse_ci95``, ``relmse``, ``variance``, ``bias2``, ``flip``, ``time``,
    ``efficiency``, ``slope``, ...; see ``docs/comparisons.md``); :meth:`to_pandas` makes them
    a DataFrame, :meth:`convergence` the convergence curves, :meth:`error_spectrum` the error
    spectra. ``images`` maps each contestant's
    label to the image of its first run, ``reference`` is the
    reference image, and ``out`` the folder with the page (``index.html``).
    """

    def __init__(self, report: dict, out: Path):
        self.report = report
        self.rows: list = report["rows"]
        self.out = out
        self._images: Optional[dict] = None

    @property
    def labels(self) -> list:
        """The contestants' labels, in order."""
        return [r["label"] for r in self.rows]

    @property
    def images(self) -> dict:
        """Each contestant's image, by label, as float32 (H, W, 3)."""
        if self._images is None:
            self._images = {label: read(self.out / f"{label}.exr") for label in self.labels}
        return self._images

    @property
    def reference(self) -> np.ndarray:
        """The reference image."""
        return read(self.out / "reference.exr")

    def to_pandas(self):
        """The rows as a pandas DataFrame, one row per contestant (region figures as
        ``region_*`` columns; the curves are in :meth:`convergence`)."""
        import pandas as pd

        flat = []
        for row in self.rows:
            skip = ("convergence", "region", "mean", "error_spectrum")
            r = {k: v for k, v in row.items() if k not in skip}
            r["mean_r"], r["mean_g"], r["mean_b"] = row["mean"]
            for k, v in (row.get("region") or {}).items():
                r[f"region_{k}"] = v
            flat.append(r)
        return pd.DataFrame(flat).set_index("label")

    def error_spectrum(self):
        """The error spectra (Celarek et al. 2019): a DataFrame of ``label``, ``frequency``
        (cycles per pixel) and ``power`` (of the error image, radially averaged, mean over
        the runs)."""
        import pandas as pd

        points = [
            {"label": row["label"], "frequency": f, "power": float("nan") if p is None else p}
            for row in self.rows
            for f, p in zip(self.report["spectrum_frequencies"], row["error_spectrum"])
        ]
        return pd.DataFrame(points, columns=["label", "frequency", "power"])

    def convergence(self):
        """The mean convergence curves: a DataFrame of ``label``, ``spp``, ``time``, ``mse``
        and ``relmse``."""
        import pandas as pd

        points = [
            {"label": row["label"], **point}
            for row in self.rows
            for point in row["convergence"]
        ]
        return pd.DataFrame(points, columns=["label", "spp", "time", "mse", "relmse"])

    def __repr__(self) -> str:
        return f"<raylab.Comparison of {', '.join(self.labels)} in {self.out}>"


def _text(value: Any) -> str:
    """A parameter's value as the command line takes it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and math.isinf(value):
        return "unlimited"
    return str(value)


def _rgb_array(a, what: str) -> np.ndarray:
    """``a`` as contiguous float32 of shape (H, W, 3)."""
    a = np.ascontiguousarray(a, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"{what} must have shape (height, width, 3), not {a.shape}")
    return a


def _json(fields: Mapping[str, Any]) -> str:
    """Fields as JSON, numpy values as plain numbers and lists."""

    def plain(v):
        if isinstance(v, np.ndarray):
            return v.tolist()
        if isinstance(v, np.generic):
            return v.item()
        raise TypeError(f"{v!r} is not a number, a string or a sequence")

    return json.dumps(fields, default=plain)
