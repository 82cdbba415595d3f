"""`cavewalk models prepare`: the same bytes from the same packages, the int8 check with its
fall-back to float32, and what the models' JSON records (issue 15 S2, issue 17)."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path

import onnx
import onnxruntime as ort
import pytest

from pipeline.demo_data import DemoData
from pipeline.machine import MachineFacts, extensions_of, machine_facts, parse_cpuinfo
from pipeline.pose.config import PoseConfig
from pipeline.pose.model_files import int8_path, usable_model_path
from pipeline.pose.prepare import (
    PreparedModel,
    canonicalize_onnx,
    package_versions,
    prepare_int8_model,
    sha256_file,
    verify_onnx,
)
from pipeline.pose.quantize import Int8Recipe, check_criteria

CPUINFO = """processor\t: 0
vendor_id\t: GenuineIntel
model name\t: Intel(R) Xeon(R) Platinum 8480+
flags\t\t: fpu sse4_2 avx avx2 fma avx512f avx512bw avx512_vnni avx512_bf16 amx_tile amx_int8

processor\t: 1
model name\t: Intel(R) Xeon(R) Platinum 8480+
"""


def test_canonical_files_of_two_exports_are_the_same_bytes(pose_model_path: Path, tmp_path: Path) -> None:
    """What differed between two exports with the same packages (issue 15: sha256 a76c... and
    cd8d...): the symbolic shapes in value_info, the export time, the metadata's order."""
    a, b = tmp_path / "a.onnx", tmp_path / "b.onnx"
    model = onnx.load(str(pose_model_path))
    exports = ((a, ("2026-12-01T19:22:46", "floor(2.0*h)")), (b, ("2026-12-01T19:26:20", "h")))
    for path, (date, dim) in exports:
        m = onnx.ModelProto()
        m.CopyFrom(model)
        info = m.graph.value_info.add()
        info.CopyFrom(onnx.helper.make_tensor_value_info("x_out", onnx.TensorProto.FLOAT, ["batch", dim]))
        entries = [(p.key, p.value) for p in m.metadata_props if p.key != "date"] + [("date", date)]
        del m.metadata_props[:]
        for key, value in (entries if path == a else entries[::-1]):
            m.metadata_props.add(key=key, value=value)
        onnx.save(m, str(path))
    assert sha256_file(a) != sha256_file(b)
    canonicalize_onnx(a)
    canonicalize_onnx(b)
    assert sha256_file(a) == sha256_file(b), "the same model, the same bytes"
    canonical = onnx.load(str(a))
    assert not canonical.graph.value_info and "date" not in {p.key for p in canonical.metadata_props}
    keys = [p.key for p in canonical.metadata_props]
    assert keys == sorted(keys) and {"kpt_shape", "stride", "names"} <= set(keys), "the rest is kept"
    assert verify_onnx(a)[1] == 56, "it still runs"
    before = sha256_file(a)
    canonicalize_onnx(a)
    assert sha256_file(a) == before, "canonical twice is canonical"


def test_machine_facts_name_the_cpu_and_onnxruntime() -> None:
    model, flags = parse_cpuinfo(CPUINFO)
    assert model == "Intel(R) Xeon(R) Platinum 8480+"
    assert extensions_of(flags) == (
        "amx", "avx2", "avx512_bf16", "avx512_bw", "avx512_vnni", "avx512f", "fma")
    xeon = MachineFacts(model, extensions_of(flags), 112, 56, 8, "Linux", "1.32.0", ("CPUExecutionProvider",))
    assert xeon.vnni and "no " not in xeon.summary() and "8 usable" in xeon.summary()
    epyc = MachineFacts("AMD EPYC", ("avx2", "fma"), 2, 2, 2, "Linux", "1.32.0", ("CPUExecutionProvider",))
    assert not epyc.vnni and "no AVX-512/VNNI/AMX" in epyc.summary()
    here = machine_facts()
    assert here.cpu_model and here.logical_cores >= here.usable_cores >= 1
    assert here.onnxruntime == ort.__version__ and "CPUExecutionProvider" in here.providers
    assert json.loads(json.dumps(here.as_dict()))["extensions"] == list(here.extensions)


def test_package_versions_name_what_made_the_models() -> None:
    versions = package_versions()
    for name in ("python", "torch", "ultralytics", "onnx", "onnxruntime", "onnxslim", "numpy",
                 "opencv-python-headless"):
        assert versions.get(name), f"{name} is recorded"
    assert versions["onnxruntime"] == ort.__version__


@pytest.mark.slow
def test_an_int8_model_that_misses_the_check_is_not_kept_and_fp32_runs_instead(
    pose_model_path: Path, demo_data: DemoData, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A deliberately degraded recipe (one calibration input, the box and keypoint branches in
    int8 too) makes an int8 model that moves boxes and keypoints: models prepare must say so and
    keep float32."""
    models = tmp_path / "models"
    models.mkdir()
    fp32_path = models / pose_model_path.name
    shutil.copy(pose_model_path, fp32_path)
    fp32 = PreparedModel(fp32_path, sha256_file(fp32_path), created=False)
    degraded = Int8Recipe(name="degraded, for the test", every=10_000, keep_head_fp32=False, max_inputs=1)
    said: list[str] = []
    cache = demo_data.root.parents[2]  # <cache>/data/pose2sim-<v>/Demo_SinglePerson
    got = prepare_int8_model(fp32, cache, progress=said.append, recipe=degraded)
    assert got is None, "a degraded int8 model is not shipped"
    target = int8_path(fp32_path)
    assert not target.exists() and not list(models.glob("*.partial")), "nothing half-made is left"
    meta = json.loads(target.with_suffix(".json").read_text())
    assert meta["rejected"] and meta["sha256"] is None and meta["check"]["ok"] is False
    assert meta["recipe"] == degraded.name and meta["source_sha256"] == fp32.sha256
    assert meta["versions"]["onnxruntime"] == ort.__version__ and meta["machine"]["cpu_model"]
    message = said[-1]
    assert "NOT kept" in message and "float32" in message and fp32_path.name in message, said
    assert any(w in meta["rejected"] for w in ("IoU", "keypoints", "people")), meta["rejected"]

    with caplog.at_level(logging.WARNING):
        assert usable_model_path(target) == fp32_path
    assert "not kept" in caplog.text

    pose = PoseConfig(precision="int8")
    assert pose.model_file(models) == fp32_path, "precision int8 falls back to the float32 model"

    said.clear()
    assert prepare_int8_model(fp32, cache, progress=said.append, recipe=degraded) is None
    assert "rejected by its check" in said[-1] and len(said) == 1, "the decision is kept, not redone"

    # ... unless the check itself has changed since (a fixed check must not leave a sound model
    # refused for ever): a rejection recorded under other criteria is quantized and checked again
    meta["check"]["criteria"] = {**meta["check"]["criteria"], "crop_margin": 40.0}
    target.with_suffix(".json").write_text(json.dumps(meta))
    said.clear()
    assert prepare_int8_model(fp32, cache, progress=said.append, recipe=degraded) is None
    assert "earlier form of its check" in said[0] and "NOT kept" in said[-1], said
    assert json.loads(target.with_suffix(".json").read_text())["check"]["criteria"] == check_criteria()
