"""Module hierarchy and content hashes of a firtool --split-verilog directory (one module per file)."""
import hashlib
import os
import re

MODULE_RE = re.compile(r"^\s*module\s+(\w+)", re.M)
# An instance line as firtool writes it: `  TypeName instName (` (parameters are never emitted for Chisel modules).
INSTANCE_RE = re.compile(r"^\s*(\w+)\s+(?:#\s*\(.*?\)\s*)?(\w+)\s*\(", re.M)
# A firtool memory module: `reg [W-1:0] Memory[0:D-1];`
MEMORY_RE = re.compile(r"^\s*reg\s+(?:\[(\d+):0\]\s+)?(\w+)\s*\[0:(\d+)\]\s*;", re.M)
# firtool's macro header, written into every file once the design has one assertion. It defines
# ASSERT_VERBOSE_COND_ and STOP_COND_ only, so it means nothing to a file that never uses them.
FIRTOOL_MACRO_HEADER_RE = re.compile(
    r"// Standard header to adapt well known macros for prints and assertions\.\n.*?`endif // not def STOP_COND_\n\n",
    re.S)
KEYWORDS = {"module", "input", "output", "inout", "wire", "reg", "assign", "always", "if", "else", "for",
            "begin", "end", "initial", "function", "task", "case", "endcase", "localparam", "parameter", "logic"}


class Design:
    """The .sv files of one directory: which file defines which module, who instantiates whom."""

    def __init__(self, verilog_dir):
        self.dir = verilog_dir
        self.files = sorted(f for f in os.listdir(verilog_dir) if f.endswith(".sv") or f.endswith(".v"))
        if not self.files:
            raise ValueError(f"no .sv files in {verilog_dir}")
        self.text = {}
        for f in self.files:
            with open(os.path.join(verilog_dir, f)) as fh:
                self.text[f] = fh.read()
        self.file_of = {}
        for f in self.files:
            for name in MODULE_RE.findall(self.text[f]):
                if name in self.file_of:
                    raise ValueError(f"module {name} defined in both {self.file_of[name]} and {f}")
                self.file_of[name] = f
        # Files without a module (macro headers) go into every closure: they can change any module's meaning.
        self.headers = [f for f in self.files if not MODULE_RE.search(self.text[f])]
        self.children = {}
        self.instances = {}  # module -> [(type, instance name)]
        for name, f in self.file_of.items():
            body = self._module_body(name)
            counts, insts = {}, []
            for typ, inst in INSTANCE_RE.findall(body):
                if typ in self.file_of and typ not in KEYWORDS and typ != name:
                    counts[typ] = counts.get(typ, 0) + 1
                    insts.append((typ, inst))
            self.children[name] = counts
            self.instances[name] = insts

    def _module_body(self, name):
        text = self.text[self.file_of[name]]
        start = re.search(r"^\s*module\s+%s\b" % re.escape(name), text, re.M).start()
        end = text.find("endmodule", start)
        return text[start:end if end >= 0 else len(text)]

    def closure(self, top):
        """`top` and every module below it."""
        seen, todo = [], [top]
        while todo:
            m = todo.pop()
            if m in seen:
                continue
            seen.append(m)
            todo.extend(self.children.get(m, {}))
        return sorted(seen)

    def reachable(self, top, skip=()):
        """`top` and the modules below it, not descending into instances of the modules in `skip`."""
        seen, todo = set(), [top]
        while todo:
            m = todo.pop()
            if m not in seen:
                seen.add(m)
                todo.extend(c for c in self.children.get(m, {}) if c not in skip)
        return seen

    def closure_files(self, top):
        return sorted(set(self.headers) | {self.file_of[m] for m in self.closure(top)})

    def content_hash(self, top, salt):
        """sha256 over the text of every file `top` depends on (names included), salted with the flow's identity."""
        h = hashlib.sha256(salt.encode())
        for f in self.closure_files(top):
            h.update(b"\0" + f.encode() + b"\0" + self.hashed_text(f).encode())
        return h.hexdigest()

    def hashed_text(self, f):
        """The file's text without firtool's macro header when the file does not use those macros, so that an
        assertion added in one module does not change every other module's cache key."""
        text = self.text[f]
        header = FIRTOOL_MACRO_HEADER_RE.search(text)
        if header is None:
            return text
        rest = text[:header.start()] + text[header.end():]
        return text if re.search(r"`(ASSERT_VERBOSE_COND_|STOP_COND_)", rest) else rest

    def memories(self, top):
        """Memories declared below `top`: (module, array, width, depth, sync_read). A SyncReadMem's firtool
        module registers the read address (`_R0_addr_d0`) or the word read; a Mem (a Queue's storage) reads
        combinationally."""
        found = []
        for m in self.closure(top):
            body = self._module_body(m)
            for hi, arr, last in MEMORY_RE.findall(body):
                width = int(hi) + 1 if hi else 1
                sync = (re.search(r"_R\d+_addr_d\d+\s*<=", body) is not None
                        or re.search(r"<=\s*%s\s*\[" % re.escape(arr), body) is not None)
                found.append({"module": m, "array": arr, "width": width, "depth": int(last) + 1,
                              "bits": width * (int(last) + 1), "sync_read": sync})
        return found

    def memory_instances(self, top, skip=()):
        """Every memory below `top` by hierarchical path as Yosys names it after flattening (inst.inst.array),
        not descending into instances of the modules in `skip`."""
        mems = {}
        for m in self.memories(top):
            mems.setdefault(m["module"], []).append(m)
        found = []

        def walk(module, prefix):
            for mem in mems.get(module, []):
                found.append(dict(mem, path=prefix + mem["array"]))
            for typ, inst in self.instances.get(module, []):
                if typ not in skip:
                    walk(typ, prefix + inst + ".")
        walk(top, "")
        return found

    def is_memory_module(self, name):
        """A firtool memory wrapper (an array, no instances). Synthesised alone it loses the context that lets
        Yosys map it to block RAM, so it always stays with the module that uses it."""
        return not self.instances.get(name) and MEMORY_RE.search(self._module_body(name)) is not None

    def stages(self, top):
        """The children of `top` that the per-module flow synthesises on their own, with instance counts."""
        return {m: n for m, n in self.children.get(top, {}).items() if not self.is_memory_module(m)}
