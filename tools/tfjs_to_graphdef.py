#!/usr/bin/python3
"""Converts a TensorFlow.js graph model (model.json + weight shards) into a frozen TensorFlow
GraphDef (.pb) that OpenCV 4.6's cv::dnn::readNetFromTensorflow loads.

    tfjs_to_graphdef.py --proto-dir DIR MODEL.json OUT.pb --output NAME [--output NAME ...]

--proto-dir is where `protoc --python_out` put tf_graph_pb2.py (compiled from tools/tf_graph.proto
by .ci/fetch-models.sh). Needs only Debian's python3 and python3-protobuf.

What it changes, and why (OpenCV's TensorFlow importer reads a narrower dialect than TF.js writes):
  * weights: TF.js keeps constants' values in binary shards, fp16-quantised here; they become the
    Const nodes' tensors again, as float32 (int32 stays int32). A tensor of one element is written
    as float_val / int_val, not as raw bytes: OpenCV reads e.g. ConcatV2's axis through int_val.
  * fused ops: _FusedConv2D and FusedDepthwiseConv2dNative (Grappler's fusions, which OpenCV does
    not know) are split back into Conv2D / DepthwiseConv2dNative + BiasAdd (+ Relu / Relu6 / Elu);
    the last node of the chain keeps the fused node's name, so its consumers are unchanged.
  * outputs: the graph is cut to the nodes the requested outputs need (e.g. CenterNet's in-graph
    top-k decoder, made of ops OpenCV lacks, is dropped); an output that is an Identity node is
    removed and its name given to the node it forwards.
  * attributes only Grappler reads (names starting with "_") are dropped.

The output is deterministic: same input bytes, same output bytes (nodes in topological order of
the input's node list, attributes serialised sorted by key).
"""

import argparse
import base64
import json
import os
import struct
import sys


def load_pb2(proto_dir):
    sys.path.insert(0, proto_dir)
    import tf_graph_pb2  # noqa: E402  (generated at set-up time)
    return tf_graph_pb2


DTYPE_SIZE = {"float32": 4, "int32": 4, "float16": 2, "uint8": 1, "uint16": 2, "bool": 1}


def read_weights(model_json, model_dir):
    """Returns {name: (dtype, shape, values as a Python list)} for every weight in the manifest."""
    weights = {}
    for group in model_json["weightsManifest"]:
        data = b"".join(open(os.path.join(model_dir, p), "rb").read() for p in group["paths"])
        offset = 0
        for w in group["weights"]:
            count = 1
            for d in w["shape"]:
                count *= int(d)
            quant = w.get("quantization")
            if quant is None:
                stored = w["dtype"]
            elif quant["dtype"] == "float16":
                stored = "float16"
            else:
                raise ValueError(f"{w['name']}: unsupported quantisation {quant}")
            size = count * DTYPE_SIZE[stored]
            chunk = data[offset:offset + size]
            if len(chunk) != size:
                raise ValueError(f"{w['name']}: weight shard too short")
            offset += size
            fmt = {"float32": "f", "int32": "i", "float16": "e"}.get(stored)
            if fmt is None:
                raise ValueError(f"{w['name']}: unsupported dtype {stored}")
            values = list(struct.unpack(f"<{count}{fmt}", chunk))
            weights[w["name"]] = (w["dtype"], [int(d) for d in w["shape"]], values)
    return weights


def set_shape(pb2_shape, json_shape):
    for d in json_shape.get("dim", []):
        pb2_shape.dim.add().size = int(d.get("size", "0"))
    if json_shape.get("unknownRank"):
        pb2_shape.unknown_rank = True


def set_attr(pb2, attr, value):
    """Copies one TF.js JSON attribute (protobuf JSON mapping of AttrValue) into `attr`."""
    if "s" in value:
        attr.s = base64.b64decode(value["s"])
    elif "i" in value:
        attr.i = int(value["i"])
    elif "f" in value:
        attr.f = float(value["f"])
    elif "b" in value:
        attr.b = bool(value["b"])
    elif "type" in value:
        attr.type = pb2.DataType.Value(value["type"])
    elif "shape" in value:
        set_shape(attr.shape, value["shape"])
    elif "list" in value:
        lst = value["list"]
        attr.list.SetInParent()
        for s in lst.get("s", []):
            attr.list.s.append(base64.b64decode(s))
        attr.list.i.extend(int(i) for i in lst.get("i", []))
        attr.list.f.extend(float(f) for f in lst.get("f", []))
        attr.list.b.extend(bool(b) for b in lst.get("b", []))
        attr.list.type.extend(pb2.DataType.Value(t) for t in lst.get("type", []))
        for shp in lst.get("shape", []):
            set_shape(attr.list.shape.add(), shp)
    elif "tensor" in value:
        raise ValueError("tensor attributes are filled from the weights")
    else:
        raise ValueError(f"unsupported attribute {value}")


def const_tensor(pb2, tensor, dtype, shape, values):
    if dtype == "float32":
        tensor.dtype = pb2.DT_FLOAT
    elif dtype == "int32":
        tensor.dtype = pb2.DT_INT32
    else:
        raise ValueError(f"unsupported constant dtype {dtype}")
    tensor.tensor_shape.SetInParent()
    for d in shape:
        tensor.tensor_shape.dim.add().size = d
    if len(values) == 1:
        # OpenCV reads scalars (ConcatV2's axis, ...) through the typed fields.
        (tensor.float_val if dtype == "float32" else tensor.int_val).append(values[0])
    else:
        fmt = "f" if dtype == "float32" else "i"
        tensor.tensor_content = struct.pack(f"<{len(values)}{fmt}", *values)


ACTIVATIONS = {"Relu", "Relu6", "Elu"}


def split_fused(node):
    """Returns a list of plain JSON nodes for a fused convolution node, else [node]."""
    op = node["op"]
    if op not in ("_FusedConv2D", "FusedDepthwiseConv2dNative"):
        return [node]
    attr = node.get("attr", {})
    fused = [base64.b64decode(s).decode() for s in attr.get("fused_ops", {}).get("list", {}).get("s", [])]
    if not fused or fused[0] != "BiasAdd" or len(fused) > 2 or (len(fused) == 2 and fused[1] not in ACTIVATIONS):
        raise ValueError(f"{node['name']}: unsupported fusion {fused}")
    if int(attr.get("num_args", {}).get("i", "1")) != 1:
        raise ValueError(f"{node['name']}: expected one fused argument (the bias)")
    name = node["name"]
    inputs = node["input"]
    conv_op = "Conv2D" if op == "_FusedConv2D" else "DepthwiseConv2dNative"
    keep = {"T", "strides", "padding", "data_format", "dilations", "explicit_paddings"}
    if conv_op == "Conv2D":
        keep.add("use_cudnn_on_gpu")
    conv_attr = {k: v for k, v in attr.items() if k in keep}
    chain = [{"name": name + "/conv", "op": conv_op, "input": inputs[:2], "attr": conv_attr}]
    bias_name = name if len(fused) == 1 else name + "/bias"
    chain.append({"name": bias_name, "op": "BiasAdd", "input": [chain[0]["name"], inputs[2]],
                  "attr": {k: v for k, v in attr.items() if k in ("T", "data_format")}})
    if len(fused) == 2:
        chain.append({"name": name, "op": fused[1], "input": [bias_name],
                      "attr": {k: v for k, v in attr.items() if k == "T"}})
    return chain


def input_node(name):
    name = name.lstrip("^")
    return name.split(":")[0]


def convert(model_path, out_path, outputs, pb2):
    model_json = json.load(open(model_path))
    weights = read_weights(model_json, os.path.dirname(os.path.abspath(model_path)))
    nodes = model_json["modelTopology"]["node"]
    by_name = {n["name"]: n for n in nodes}

    # Identity outputs: the producer takes the output's name.
    rename = {}
    for out in outputs:
        if out not in by_name:
            raise ValueError(f"output {out} is not a node of {model_path}")
        node = by_name[out]
        if node["op"] == "Identity":
            rename[input_node(node["input"][0])] = out
    drop = set(rename.values())

    def mapped(name):
        base = input_node(name)
        if base in drop:  # a consumer of the Identity reads its producer, now of the same name
            return name
        return name.replace(base, rename[base], 1) if base in rename else name

    # Keep only what the outputs need.
    needed = set()
    stack = [input_node(by_name[o]["input"][0]) if o in drop else o for o in outputs]
    while stack:
        name = stack.pop()
        if name in needed:
            continue
        needed.add(name)
        stack.extend(input_node(i) for i in by_name[name].get("input", []))

    graph = pb2.GraphDef()
    graph.versions.producer = int(model_json["modelTopology"].get("versions", {}).get("producer", 0) or 0)
    for node in nodes:
        if node["name"] not in needed:
            continue
        for part in split_fused(node):
            out = graph.node.add()
            out.name = rename.get(part["name"], part["name"])
            out.op = part["op"]
            out.input.extend(mapped(i) for i in part.get("input", []))
            for key in sorted(part.get("attr", {})):
                if key.startswith("_") or (part["op"] == "Const" and key == "value"):
                    continue
                set_attr(pb2, out.attr[key], part["attr"][key])
            if part["op"] == "Const":
                if part["name"] not in weights:
                    raise ValueError(f"constant {part['name']} has no weights")
                dtype, shape, values = weights[part["name"]]
                const_tensor(pb2, out.attr["value"].tensor, dtype, shape, values)
    data = graph.SerializeToString(deterministic=True)
    tmp = out_path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, out_path)
    return len(graph.node)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model_json")
    parser.add_argument("out_pb")
    parser.add_argument("--output", action="append", required=True, help="output node (repeatable)")
    parser.add_argument("--proto-dir", required=True, help="folder holding tf_graph_pb2.py")
    args = parser.parse_args()
    try:
        count = convert(args.model_json, args.out_pb, args.output, load_pb2(args.proto_dir))
    except (OSError, ValueError, KeyError) as e:
        print(f"tfjs_to_graphdef: {args.model_json}: {e}", file=sys.stderr)
        return 1
    print(f"tfjs_to_graphdef: {args.out_pb}: {count} nodes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
