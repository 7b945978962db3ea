#!/usr/bin/python3
"""netkf_msgs/msg/*.msg are field-for-field twins of idl/netkf.idl (docs/ros2.md): a network
launched with --naming ros2 sends the wire types under ROS 2 names, and a ROS 2 node decodes the
bytes with the .msg, so each .msg must list the same fields, in the same order, of the types
the IDL's map to (names may only differ in case: ROS 2 field names are lower case). Every wire
struct has its .msg, and the package's CMakeLists.txt generates each.

The IDL and the .msg files are parsed here independently of netkf's code (fastddsgen reads the
IDL for netkf; rosidl reads the .msg on a ROS 2 machine)."""
import os
import re
import sys

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
IDL_TO_MSG = {
    "double": "float64", "float": "float32", "long": "int32", "long long": "int64", "unsigned long": "uint32",
    "unsigned long long": "uint64", "short": "int16", "unsigned short": "uint16", "boolean": "bool",
    "octet": "byte", "string": "string",
}


def idl_structs(path):
    """{struct name: [(msg type, field name)]} of the IDL's structs (one module level: netkf::wire)."""
    with open(path, encoding="utf-8") as f:
        text = re.sub(r"//[^\n]*", "", f.read())
    structs = {}
    for name, body in re.findall(r"struct\s+(\w+)\s*\{(.*?)\};", text, re.S):
        fields = []
        for decl in (d.strip() for d in body.split(";")):
            if not decl:
                continue
            decl = re.sub(r"@key\s+", "", decl)
            m = re.fullmatch(r"(sequence\s*<\s*([\w ]+?)\s*(?:,\s*(\d+))?\s*>|[\w ]+?)\s+(\w+)", decl)
            if not m:
                raise AssertionError("%s: cannot read the field %r of %s" % (path, decl, name))
            whole, element, bound, field = m.groups()
            if element is not None:
                base = IDL_TO_MSG.get(element, element)
                msg_type = base + ("[<=%s]" % bound if bound else "[]")
            else:
                msg_type = IDL_TO_MSG.get(whole, whole)
            fields.append((msg_type, field))
        structs[name] = fields
    return structs


def msg_fields(path):
    fields = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            text = line.split("#", 1)[0].strip()
            if text:
                msg_type, field = text.split()
                fields.append((msg_type, field))
    return fields


def main():
    structs = idl_structs(os.path.join(REPO, "idl", "netkf.idl"))
    msg_dir = os.path.join(REPO, "netkf_msgs", "msg")
    msgs = {f[:-4]: msg_fields(os.path.join(msg_dir, f)) for f in os.listdir(msg_dir) if f.endswith(".msg")}
    problems = []
    if set(structs) != set(msgs):
        problems.append("wire structs without a .msg: %s; .msg without a wire struct: %s"
                        % (sorted(set(structs) - set(msgs)), sorted(set(msgs) - set(structs))))
    for name in sorted(set(structs) & set(msgs)):
        idl, msg = structs[name], msgs[name]
        if len(idl) != len(msg):
            problems.append("%s: %d fields in the IDL, %d in the .msg" % (name, len(idl), len(msg)))
        for i, ((it, iname), (mt, mname)) in enumerate(zip(idl, msg)):
            if it != mt or iname.lower() != mname:
                problems.append("%s field %d: IDL %s %s, .msg %s %s" % (name, i, it, iname, mt, mname))
            if not re.fullmatch(r"[a-z][a-z0-9_]*", mname):
                problems.append("%s field %s: not a ROS 2 field name" % (name, mname))
    with open(os.path.join(REPO, "netkf_msgs", "CMakeLists.txt")) as f:
        generated = set(re.findall(r'"msg/(\w+)\.msg"', f.read()))
    if generated != set(msgs):
        problems.append("netkf_msgs/CMakeLists.txt generates %s, the package has %s" % (sorted(generated), sorted(msgs)))
    checked = sum(len(v) for v in structs.values())
    if len(structs) < 13 or checked < 100:
        problems.append("read only %d structs, %d fields of idl/netkf.idl" % (len(structs), checked))
    for p in problems:
        print("FAIL:", p)
    print("%d wire types, %d fields compared with netkf_msgs/msg" % (len(structs), checked))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
