"""Writes the hostile corpus' ONNX models (tests/hostile/models.toml): valid ONNX graphs that are
not a YOLOv8 detector. Run with a Python that has the `onnx` package:
    python tests/hostile/models/make.py
"""
from pathlib import Path

import onnx
from onnx import TensorProto, helper

HERE = Path(__file__).parent


def identity(name, shape):
    """An Identity graph from `images` to `output0`, both of `shape` (float32)."""
    x = helper.make_tensor_value_info("images", TensorProto.FLOAT, shape)
    y = helper.make_tensor_value_info("output0", TensorProto.FLOAT, shape)
    graph = helper.make_graph([helper.make_node("Identity", ["images"], ["output0"])], name, [x], [y])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, HERE / f"{name}.onnx")


# Four channels (RGBA) where YOLOv8 takes three (RGB), or one (grey).
identity("wrong-input", [1, 4, 640, 640])
# The right input, but the output is the image itself, not (1, 4 + classes, anchors) boxes.
identity("wrong-output", [1, 3, 640, 640])
