"""UTD-MHAD as labelled recordings: one recording per trial, labelled with its action.

The trials are read by `imukit.datasets.utd_mhad` (SI units, sensor axes as recorded). The
sensor is named by where it was worn (`right_wrist` for actions 1-21, `right_thigh` for 22-27);
the model sees the same six channels either way, as in the dataset. Class k is action k + 1.

With `scenes=FOLDER`, a trial whose fitted scene exists (`FOLDER/<a_s_t>/scene.json`, what the
UTD-MHAD fitting batch writes) gets it as its `scene`; the scene's sensor is the one named as the
trial's site (or the scene's only sensor). The batch bakes the fitted time offset and clock rate
into the scene's motion (scene sample k is IMU sample k), so no offset is applied here; the
fitted constant biases come from the folder's `placement.json` (`imukit.placement/1`:
`accelerometer.bias_mps2`, `gyroscope.bias_radps`) when there is one.
"""
import json
import os

import numpy as np

from ..datasets import utd_mhad as reader
from .recordings import FormatError, Recording, Recordings, SceneRef, read_json_object


def scene_ref(folder, site):
    """The SceneRef of one fitted-scene folder, or None when it has no scene.json; a scene.json
    or placement.json that is not a JSON object is a FormatError naming the file (and line:column:
    found in review, the message of a truncated one named neither)."""
    path = os.path.join(folder, "scene.json")
    if not os.path.exists(path):
        return None
    doc = read_json_object(path)
    sensors = doc.get("sensors", [])
    if not isinstance(sensors, list) or not all(isinstance(s, dict) for s in sensors):
        raise FormatError(f"{path}: sensors: expected a list of objects")
    names = [s.get("name", s.get("preset")) for s in sensors]
    if site in names:
        sensor = site
    elif len(names) == 1:
        sensor = names[0]
    else:
        raise ValueError(f"{path}: no sensor named '{site}' among {names}")
    bias = None
    placement = os.path.join(folder, "placement.json")
    if os.path.exists(placement):
        p = read_json_object(placement)
        ba = _bias(p, placement, "accelerometer", "bias_mps2")
        bg = _bias(p, placement, "gyroscope", "bias_radps")
        if ba is not None or bg is not None:
            bias = np.array([list(ba or [0.0] * 3) + list(bg or [0.0] * 3)], np.float64)
    return SceneRef(path=path, sensors=[sensor], time_offset_s=0.0, bias=bias)


def _bias(placement, path, sensor, key):
    """placement[sensor][key]: None or three finite numbers; FormatError naming the file and key
    otherwise (found in review: a list where an object belongs was an AttributeError traceback)."""
    part = placement.get(sensor, {})
    if not isinstance(part, dict):
        raise FormatError(f"{path}: {sensor}: expected an object")
    v = part.get(key)
    if v is None:
        return None
    if (not isinstance(v, list) or len(v) != 3
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x) for x in v)):
        raise FormatError(f"{path}: {sensor}.{key}: expected three finite numbers, got {json.dumps(v)}")
    return v


def load(root, scenes=None, subjects=None, actions=None):
    """Every paired trial of UTD-MHAD at `root` (optionally only some subjects 1..8 / actions
    1..27) as Recordings; subject ids are "s1" .. "s8"."""
    trials, _ = reader.list_trials(root)
    out = []
    for t in trials:
        if subjects is not None and t.subject not in subjects:
            continue
        if actions is not None and t.action not in actions:
            continue
        trial = reader.load_trial(root, t)
        x = np.concatenate([trial.accel, trial.gyro], axis=1)
        scene = scene_ref(os.path.join(scenes, t.stem), trial.site) if scenes else None
        out.append(Recording(id=t.stem, subject=f"s{t.subject}", samples=x,
                             labels=np.full(len(x), t.action - 1, np.int64),
                             rate_hz=trial.imu_rate_hz, sensors=[trial.site], scene=scene))
    return Recordings(name="UTD-MHAD", classes=list(reader.ACTIONS), recordings=out)
