"""Writes the generated parts of python/formfactor/__init__.pyi: the methods and functions bound
from keyword tables in C++ (python/src/keywords.h), as formfactor._core._signatures() describes
them, between the lines ``# <generated Owner>`` (a class, or ``module`` for the module's
functions) and ``# </generated>`` of the stub.

    PYTHONPATH=build/python /usr/bin/python3 python/generate_stub.py          # rewrite the stub
    PYTHONPATH=build/python /usr/bin/python3 python/generate_stub.py --check  # exit 1 if stale
"""

import pathlib
import re
import sys

STUB = pathlib.Path(__file__).resolve().parent / "formfactor" / "__init__.pyi"
WIDTH = 100


def method_stub(sig, indent):
    params = [] if sig["owner"] == "module" else ["self"]
    star = False
    for k in sig["keywords"]:
        if not k["positional"] and not star:
            params.append("*")
            star = True
        # An empty default: a required argument.
        params.append("%s: %s%s" % (k["name"], k["type"], " = ..." if k["default"] else ""))
    head = indent + "def %s(" % sig["name"]
    params[-1] += ") -> %s: ..." % sig["returns"]
    lines = [head]
    for k, p in enumerate(params):
        piece = p + ("," if k + 1 < len(params) else "")
        if len(lines[-1]) + 1 + len(piece) > WIDTH and lines[-1].strip():
            lines[-1] = lines[-1].rstrip()
            lines.append(" " * len(head))
        lines[-1] += piece + " "
    return "\n".join(line.rstrip() for line in lines)


def generated(signatures, owner, indent):
    return "\n".join(method_stub(s, indent) for s in signatures if s["owner"] == owner)


def render(text, signatures):
    pattern = re.compile(r"^( *)# <generated (\w+)>\n.*?^ *# </generated>$", re.S | re.M)

    def block(m):
        indent, owner = m.group(1), m.group(2)
        return "%s# <generated %s>\n%s\n%s# </generated>" % (
            indent, owner, generated(signatures, owner, indent), indent)

    return pattern.sub(block, text)


def main(argv):
    # The built package (PYTHONPATH), not the sources beside this script, which lack _core.
    here = str(STUB.parent.parent)
    sys.path[:] = [p for p in sys.path if str(pathlib.Path(p or ".").resolve()) != here]
    from formfactor import _core

    text = STUB.read_text()
    new = render(text, _core._signatures())
    if "--check" in argv:
        if new != text:
            print("%s is stale: run python/generate_stub.py" % STUB)
            return 1
        return 0
    STUB.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
