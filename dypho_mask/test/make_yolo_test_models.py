#!/usr/bin/env python3
"""Writes small ONNX models with the output layouts of YOLO exports and KNOWN outputs, for the
decoder tests (run at build/test time into the build dir; nothing binary is committed).

Each model takes `images` 1x3xSxS and returns constant tensors (plus 0 * mean(images), so the
outputs depend on the input and OpenCV's importer keeps a real graph):
  yolov8_seg.onnx  output0 1x(4+nc+32)xN, output1 1x32xMHxMW
  yolov5_seg.onnx  output0 1xNx(5+nc+32), output1 1x32xMHxMW
  yolov8_det.onnx  output0 1x(4+nc)xN
  wrong_layout.onnx output0 1x7x5x3 (4-D, no YOLO layout)
  corrupt.onnx     not ONNX at all
The expected content (boxes, classes, mask region) is written in the docstring of make_seg and
asserted by dypho_mask/test/test_yolo_onnx.cpp.

usage: make_yolo_test_models.py OUT_DIR
"""
import os
import sys

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

S = 64          # network input size
NC = 3          # classes
NM = 32         # mask coefficients
MH = MW = 16    # prototype size
N = 64          # candidates (N > channels, as in real exports: the auto layout rule relies on it)


def graph_with_constants(name, outputs):
    """outputs: list of (name, numpy array). out = const + 0 * (the first numel input values),
    flattened, sliced and reshaped (OpenCV 4.6 imports this; broadcasting Add/Tile it does not)."""
    nodes = [helper.make_node("Reshape", ["images", "flat_shape"], ["flat"])]
    inits = [numpy_helper.from_array(np.array([1, 3 * S * S], np.int64), "flat_shape")]
    outs = []
    for oname, arr in outputs:
        arr = arr.astype(np.float32)
        assert arr.size <= 3 * S * S
        inits += [numpy_helper.from_array(arr, oname + "_const"),
                  numpy_helper.from_array(np.zeros(arr.shape, np.float32), oname + "_zero"),
                  numpy_helper.from_array(np.array([0], np.int64), oname + "_st"),
                  numpy_helper.from_array(np.array([arr.size], np.int64), oname + "_en"),
                  numpy_helper.from_array(np.array([1], np.int64), oname + "_ax"),
                  numpy_helper.from_array(np.array(arr.shape, np.int64), oname + "_shape")]
        nodes += [helper.make_node("Slice", ["flat", oname + "_st", oname + "_en", oname + "_ax"], [oname + "_sl"]),
                  helper.make_node("Reshape", [oname + "_sl", oname + "_shape"], [oname + "_r"]),
                  helper.make_node("Mul", [oname + "_r", oname + "_zero"], [oname + "_z"]),
                  helper.make_node("Add", [oname + "_const", oname + "_z"], [oname])]
        outs.append(helper.make_tensor_value_info(oname, TensorProto.FLOAT, list(arr.shape)))
    g = helper.make_graph(nodes, name, [helper.make_tensor_value_info("images", TensorProto.FLOAT, [1, 3, S, S])],
                          outs, inits)
    m = helper.make_model(g, opset_imports=[helper.make_opsetid("", 11)])
    m.ir_version = 6
    onnx.checker.check_model(m)
    return m


def protos():
    """Prototype 0 is +8 inside input rows/cols [16, 48) (the centre square), -8 elsewhere; the
    others are 0. A detection with coefficient 1 on prototype 0 has a mask = the centre square."""
    p = np.zeros((1, NM, MH, MW), np.float32)
    p[0, 0] = -8.0
    p[0, 0, 4:12, 4:12] = 8.0
    return p


def candidates():
    """Rows: (cx, cy, w, h, class scores..., coeffs...) in input px.
    0: person (class 0) 0.9, box centre (32, 32) size 40x40, coeff0 = 1 -> mask = centre square
    1: class 2 0.8, box (10, 10) 8x8, coeff0 = 1
    2: person 0.85 duplicate of 0 shifted by 1 px -> removed by NMS
    3..: scores 0.01 (below threshold)"""
    rows = []
    for i in range(N):
        r = np.zeros(4 + NC + NM, np.float32)
        r[4:4 + NC] = 0.01
        rows.append(r)
    rows[0][:4] = [32, 32, 40, 40]; rows[0][4 + 0] = 0.9; rows[0][4 + NC] = 1.0
    rows[1][:4] = [10, 10, 8, 8];   rows[1][4 + 2] = 0.8; rows[1][4 + NC] = 1.0
    rows[2][:4] = [33, 32, 40, 40]; rows[2][4 + 0] = 0.85; rows[2][4 + NC] = 1.0
    return np.stack(rows)  # N x (4 + NC + NM)


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    c = candidates()
    v8 = c.T[None]                                            # 1 x (4+NC+NM) x N
    onnx.save(graph_with_constants("v8seg", [("output0", v8), ("output1", protos())]),
              os.path.join(out, "yolov8_seg.onnx"))
    # v5: insert objectness 1.0 after the box; class scores unchanged.
    v5 = np.concatenate([c[:, :4], np.ones((N, 1), np.float32), c[:, 4:]], axis=1)[None]
    onnx.save(graph_with_constants("v5seg", [("output0", v5), ("output1", protos())]),
              os.path.join(out, "yolov5_seg.onnx"))
    det = c[:, :4 + NC].T[None]                               # 1 x (4+NC) x N
    onnx.save(graph_with_constants("v8det", [("output0", det)]), os.path.join(out, "yolov8_det.onnx"))
    onnx.save(graph_with_constants("wrong", [("output0", np.zeros((1, 7, 5, 3), np.float32))]),
              os.path.join(out, "wrong_layout.onnx"))
    with open(os.path.join(out, "corrupt.onnx"), "wb") as f:
        f.write(b"this is not an onnx model\x00\x01\x02")


if __name__ == "__main__":
    main()
