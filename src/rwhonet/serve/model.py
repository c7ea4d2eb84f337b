"""A served WhONet: its ONNX graph run by ONNX Runtime, and the metadata to use it.

A served model predicts, for a window of scaled wheel-speed features, the
label of the samples contract: GNSS − WPM displacement per second, the WPM
taken with the *source* calibration's rear radii (``source_radii``). For a
model whose recipe refitted those radii (``radius+G``), the network's output
is the error of the WPM with the refitted radii (``wpm_radii``), and
:meth:`ServedModel.predict_label` adds the difference between the two WPMs
(:func:`rwhonet.features.wpm.radius_corrected`, which
:func:`rwhonet.models.adapt.label_prediction` calls too); so
``corrected = WPM(source radii) + predict_label`` for every model.

The metadata (:class:`ServedMeta`, JSON) travels in the ONNX file's
``metadata_props`` under :data:`META_KEY`, and as ``rwhonet.json`` in a
model bundle. Where a model can be found (:func:`load_served`): an ``.onnx``
file, a bundle folder holding ``model.onnx``, or an MLflow model folder
(``artifacts/model.onnx``). This module never imports torch.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rwhonet.errors import InputError, Problem
from rwhonet.features.scaling import MinMaxScaler, scaler_from_dict
from rwhonet.features.wpm import WPM_MODES, radius_corrected

FORMAT = "rwhonet.served/1"
META_KEY = "rwhonet"
ONNX_FILE = "model.onnx"
TORCH_FILE = "model.pt"  # what a bundle never holds (rwhonet.serve.bundle)
SAFETENSORS_FILE = "model.safetensors"
META_FILE = "rwhonet.json"
MLFLOW_ARTIFACTS = "artifacts"  # where an MLflow pyfunc model keeps its files


@dataclass(frozen=True)
class ServedMeta:
    """What running a model needs beyond its weights, and where it came from.

    Attributes:
        hparams: the network's hyperparameters (``seq_len``, ``n_features``...).
        scaler: the input scaler (:meth:`MinMaxScaler.to_dict`), fitted on source_train.
        source_radii: the WPM's rear radii (m/rad) of the source calibration: the
            label's WPM.
        wpm_mode: ``integrated`` or ``reference`` (``label.wpm_mode``).
        wpm_radii: the rear radii the network corrects when its recipe refitted them
            (``radius+G``, ``shrink``); None: ``source_radii``.
        info: provenance as strings (model, vehicle, recipe, m, seed, drive...).
        evidence: what the ``shrink`` recipe sizes its update by, as the adapt stage's
            ``evidence.json`` holds it (``{"target": ..., "source": ...}``, each a
            :class:`rwhonet.models.adapt.ShrinkEvidence` as data, or null); None: not known.
        navigation: what the evaluation measured of the navigation filter with this
            model on its car (``vehicle``, ``receiver_sigma_m``, ``receiver_tau_s``,
            ``antenna_m`` ([ahead, left], m), ``gyro_latency_s`` and
            ``gyro_instability_deg_s`` as fitted (or null), ``outage_scale``:
            ``{outage s: γ}``, the corrected distance's variance factor inside an
            outage of that length (errors that last; empty or absent: 1),
            ``calibration``: ``{"scales": {outage s: c}, "dofs": {outage s: ν or
            null for a normal}}`` (a bundle registered before ``ν`` was fitted per
            length: one ``"dof"`` for every length), ``from``;
            :class:`rwhonet.serve.navigation.PositionCalibration`); None: not known
            (the generic filter and its own covariance).
    """

    hparams: dict[str, Any]
    scaler: dict[str, Any]
    source_radii: tuple[float, float]
    wpm_mode: str
    wpm_radii: tuple[float, float] | None = None
    info: dict[str, str] = field(default_factory=dict)
    evidence: dict[str, Any] | None = None
    navigation: dict[str, Any] | None = None

    @property
    def seq_len(self) -> int:
        return int(self.hparams["seq_len"])

    @property
    def n_features(self) -> int:
        return int(self.hparams["n_features"])

    def to_json(self) -> str:
        """The metadata as one JSON document (what ``metadata_props`` and ``rwhonet.json`` hold)."""
        return json.dumps({"format": FORMAT, **asdict(self)}, sort_keys=True)

    @classmethod
    def from_json(cls, text: str, source: str) -> ServedMeta:
        """Parse :meth:`to_json`'s document.

        Raises:
            InputError: naming the file and the field that is missing or malformed.
        """
        try:
            raw = json.loads(text)
        except json.JSONDecodeError as err:
            raise _not_served(source, "JSON metadata", f"invalid JSON ({err.msg})") from None
        if not isinstance(raw, dict) or raw.get("format") != FORMAT:
            found = raw.get("format") if isinstance(raw, dict) else type(raw).__name__
            raise _not_served(source, f"metadata format {FORMAT!r}", repr(found))
        problems = []
        hp = raw.get("hparams")
        if not (
            isinstance(hp, dict)
            and all(isinstance(hp.get(k), int) for k in ("seq_len", "n_features"))
        ):
            problems.append(Problem(source, None, "hparams", "seq_len and n_features", repr(hp)))
        for key in ("source_radii", "wpm_radii"):
            value = raw.get(key)
            if value is None and key == "wpm_radii":
                continue
            if not (
                isinstance(value, list)
                and len(value) == 2
                and all(isinstance(r, int | float) and r > 0 for r in value)
            ):
                problems.append(
                    Problem(source, None, key, "two positive radii (m/rad)", repr(value))
                )
        if not _navigation_ok(raw.get("navigation")):
            problems.append(
                Problem(
                    source,
                    None,
                    "navigation",
                    "null or {receiver_sigma_m, receiver_tau_s, antenna_m, gyro_latency_s, "
                    "gyro_instability_deg_s, outage_scale: {s: factor}, "
                    "calibration: {scales, dofs}}",
                    repr(raw.get("navigation"))[:80],
                )
            )
        if not isinstance(raw.get("evidence"), dict | None):
            problems.append(
                Problem(source, None, "evidence", "an object or null", repr(raw["evidence"])[:80])
            )
        if raw.get("wpm_mode") not in WPM_MODES:
            problems.append(
                Problem(source, None, "wpm_mode", f"one of {WPM_MODES}", repr(raw.get("wpm_mode")))
            )
        if problems:
            raise InputError(problems, f"{source}: the model's metadata is incomplete")
        scaler_from_dict(raw.get("scaler"), f"{source} (scaler)")  # checked here, once
        return cls(
            hparams=dict(hp),
            scaler=dict(raw["scaler"]),
            source_radii=(float(raw["source_radii"][0]), float(raw["source_radii"][1])),
            wpm_mode=str(raw["wpm_mode"]),
            wpm_radii=None
            if raw.get("wpm_radii") is None
            else (float(raw["wpm_radii"][0]), float(raw["wpm_radii"][1])),
            info={str(k): str(v) for k, v in (raw.get("info") or {}).items()},
            evidence=raw.get("evidence"),
            navigation=raw.get("navigation"),
        )


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _positive(value: Any) -> bool:
    return _number(value) and value > 0


def _navigation_ok(nav: Any) -> bool:
    """``navigation`` metadata as :class:`ServedMeta` documents it (or null)."""
    if nav is None:
        return True
    if not isinstance(nav, dict):
        return False
    for key in ("receiver_sigma_m", "receiver_tau_s"):
        if nav.get(key) is not None and not _positive(nav[key]):
            return False
    late = nav.get("gyro_latency_s")
    if late is not None and not (_number(late) and 0 <= late < 5):
        return False
    unstable = nav.get("gyro_instability_deg_s")
    if unstable is not None and not (_positive(unstable) and unstable < 10):
        return False
    lasting = nav.get("outage_scale", {})
    if not isinstance(lasting, dict) or not all(
        str(L).isdigit() and int(L) > 0 and _positive(g) for L, g in lasting.items()
    ):
        return False
    antenna = nav.get("antenna_m")
    if antenna is not None and not (
        isinstance(antenna, list | tuple)
        and len(antenna) == 2
        and all(_number(v) and abs(v) < 50 for v in antenna)
    ):
        return False
    cal = nav.get("calibration")
    if cal is None:
        return True
    if not isinstance(cal, dict) or not isinstance(cal.get("scales", {}), dict):
        return False
    scales, dofs = cal.get("scales", {}), cal.get("dofs", {})
    if not isinstance(dofs, dict):
        return False
    if not all(str(L).isdigit() and int(L) > 0 and _positive(c) for L, c in scales.items()):
        return False
    if not all(str(L).isdigit() and (v is None or _positive(v)) for L, v in dofs.items()):
        return False
    return cal.get("dof") is None or _positive(cal["dof"])


def _not_served(source: str, expected: str, found: str) -> InputError:
    return InputError(
        [
            Problem(
                source,
                None,
                None,
                expected,
                found,
                "give a model exported by `rwhonet export`, a model folder, or a registered "
                "model (models:/whonet-G/latest)",
            )
        ],
        f"{source} is not an rwhonet model",
    )


class ServedModel:
    """An ONNX WhONet in an ONNX Runtime session, with its metadata.

    Args:
        onnx_path: the ``.onnx`` file.
        meta: its metadata; None: read from the file's ``metadata_props``.
        threads: intra-op threads of the session (1: this network is far too small to
            gain from more, and a second core is better left to the caller).
    """

    def __init__(self, onnx_path: Path | str, meta: ServedMeta | None = None, threads: int = 1):
        import onnxruntime as ort

        self.path = Path(onnx_path)
        options = ort.SessionOptions()
        options.intra_op_num_threads = threads
        options.inter_op_num_threads = 1
        options.log_severity_level = 3  # warnings about unused initialisers etc. say nothing
        try:
            self.session = ort.InferenceSession(
                str(self.path), options, providers=["CPUExecutionProvider"]
            )
        except Exception as err:  # noqa: BLE001 - onnxruntime raises its own types
            raise _not_served(str(onnx_path), "an ONNX model", str(err)[:200]) from None
        if meta is None:
            props = self.session.get_modelmeta().custom_metadata_map
            if META_KEY not in props:
                raise _not_served(
                    str(onnx_path),
                    f"metadata_props[{META_KEY!r}] (scaler and WPM radii)",
                    "an ONNX model without them",
                )
            meta = ServedMeta.from_json(props[META_KEY], str(onnx_path))
        self.meta = meta
        self.scaler: MinMaxScaler = scaler_from_dict(meta.scaler, str(onnx_path))
        self._input = self.session.get_inputs()[0].name

    def predict(self, x: np.ndarray) -> np.ndarray:
        """The network's output, ``(n,)`` float32, for ``(n, seq_len, n_features)`` windows."""
        x = np.ascontiguousarray(x, dtype=np.float32)
        if x.ndim != 3 or x.shape[1:] != (self.meta.seq_len, self.meta.n_features):
            raise InputError(
                [
                    Problem(
                        str(self.path),
                        None,
                        "x",
                        f"windows of shape (n, {self.meta.seq_len}, {self.meta.n_features})",
                        f"shape {x.shape}",
                    )
                ],
                "inputs do not fit the model",
            )
        if len(x) == 0:
            return np.zeros(0, dtype=np.float32)
        return self.session.run(None, {self._input: x})[0]

    def predict_label(
        self,
        x: np.ndarray,
        angle_rl_rad: np.ndarray | None = None,
        angle_rr_rad: np.ndarray | None = None,
    ) -> np.ndarray:
        """The label prediction (GNSS − WPM with the source radii), float64 metres.

        Args:
            x: ``(n, seq_len, n_features)`` scaled feature windows.
            angle_rl_rad: ``(n,)`` rear-left wheel angle of each second (the WPM's mode);
                needed only by a model with its own radii.
            angle_rr_rad: ``(n,)`` rear-right wheel angle.

        Raises:
            InputError: the model has its own radii and the angles are missing.
        """
        pred = self.predict(x).astype(np.float64)
        if self.meta.wpm_radii is None:
            return pred
        if angle_rl_rad is None or angle_rr_rad is None:
            raise InputError(
                [
                    Problem(
                        str(self.path),
                        None,
                        "angle_rl_rad / angle_rr_rad",
                        "the rear wheel angles of every second (this model refitted the WPM's "
                        f"radii to {self.meta.wpm_radii})",
                        "none given",
                    )
                ],
                "inputs do not fit the model",
            )
        return radius_corrected(
            pred, angle_rl_rad, angle_rr_rad, self.meta.wpm_radii, self.meta.source_radii
        )


def onnx_file(path: Path) -> Path:
    """The ``.onnx`` file of a served model given as a file, a bundle or an MLflow model folder.

    Raises:
        InputError: nothing there, or a folder without a model.
    """
    path = Path(path)
    if path.is_file():
        return path
    for candidate in (path / ONNX_FILE, path / MLFLOW_ARTIFACTS / ONNX_FILE):
        if candidate.is_file():
            return candidate
    found = (
        "no such file or folder"
        if not path.exists()
        else (f"a folder without {ONNX_FILE} (holds {sorted(p.name for p in path.iterdir())[:6]})")
    )
    raise InputError(
        [
            Problem(
                str(path),
                None,
                None,
                f"an exported .onnx file, or a model folder holding {ONNX_FILE}",
                found,
                (
                    f"export it: `rwhonet export --model {path} --output model.onnx`, then "
                    "--model model.onnx; or give a registered model (models:/<name>/<version>)"
                )
                if path.is_dir() and (path / TORCH_FILE).is_file()
                else "export one with `rwhonet export --model ... --format onnx`, or give a "
                "registered model (models:/<name>/<version>)",
            )
        ],
        f"no model at {path}",
    )


def load_served(path: Path | str, threads: int = 1) -> ServedModel:
    """Open a served model (see :func:`onnx_file` for what ``path`` may be)."""
    return ServedModel(onnx_file(Path(path)), threads=threads)
