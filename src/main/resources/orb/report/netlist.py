#!/usr/bin/env python3
"""orb.Report's netlist helpers, on yosys / nextpnr JSON files.

`les GENERIC.json`: per module of the generic (Cyclone-II-like) netlist, the flip-flops that take a logic element
of their own: a flip-flop shares one only with the LUT or carry-chain bit that feeds its D input, and each LUT or
carry bit with one flip-flop; a flip-flop fed by another flip-flop, a port or a second flip-flop of the same LUT
takes a logic element of its own. Three kinds live in the hard blocks instead, as Quartus packs them on Cyclone II:
the only flip-flop behind a RAM read bit (the M4K's output register), a flip-flop that feeds nothing but
multiplier inputs (the multiplier's input register) and the only flip-flop behind a product bit (its output
register). Prints `module count` lines.

`pack IN.json OUT.json TOP`: moves plain registers into the RAM and multiplier blocks of a synth_ecp5 netlist.

Quartus packs an M4K's output register and a multiplier's input and output registers into the blocks on Cyclone II;
yosys maps every RAM with REGMODE NOREG and every multiplier without its registers, so the proxy would charge the
block's slow unregistered output to the next logic. This pass does what Quartus does, and only where it is exact:

- RAM (DP16KD) port X in NOREG: when every used DOX bit feeds exactly one flip-flop clocked by CLKX, with no reset
  and the same clock enable, the flip-flops become the port's output register (REGMODE_X = OUTREG, OCEX = their
  enable) and are removed;
- multiplier (MULT18X18D): an input (A or B) whose every non-constant bit comes from a flip-flop with no reset and
  one common enable that feeds only multiplier inputs becomes an input register (the flip-flop is removed once
  nothing else reads it); the product is registered likewise when every used P bit feeds exactly one such
  flip-flop; each distinct enable takes one of the block's CE0..CE3 pins (Cyclone II's multiplier registers have
  clock enables too); an input of constants only is registered with the other input (a register of a constant is
  that constant);
- an active-low enable reaches a block's enable pin through an inverter LUT, as Quartus would do it.

Prints one line: counts of what was packed.

`path REPORT.json NETLIST.json`: the critical path of a nextpnr report, as one line of JSON: source and sink
registers (net names, kept by the flow), logic levels (LUTs and carry-chain entries, not the hops inside a chain),
logic and routing delay, the largest fan-out on the path and its net, the RTL lines along it.

`slack SDF NETLIST PERIOD_NS [N]`: every failing endpoint of a routed design, from nextpnr's SDF (routed net and cell
delays, the largest of min:typ:max as nextpnr's own analysis takes): arrival times over the whole netlist, the
endpoints whose slack at PERIOD_NS is negative, grouped by source and sink register (names from NETLIST, bit indices
dropped), worst first; N groups (default 40). One routed run thus shows every path to fix, not only the worst.

`congestion PREFIX`: where a routing failed, from router2's heat maps (`--router2-heatmap PREFIX`): in the iteration
with the fewest overused wires, each block's share of the nets on them, largest
first (a net counted once per overused wire it takes), as one line.
"""
import glob
import json
import re
import sys
from collections import defaultdict


def block(name):
    """the block of a netlist name, as the report names them: core.<block> inside the core, <block> beside it
    (Spinal's instance suffix dropped), top for the core top's own nets, wrapper for the proxy's"""
    parts = name.split(".")
    if parts[0] != "dut":
        return "wrapper"
    if len(parts) > 3 and parts[1] == "core":
        return "core." + re.sub(r"_\d+$", "", parts[2])
    return re.sub(r"_\d+$", "", parts[1]) if len(parts) > 2 else "top"


def sinks_of(module):
    """net bit -> [(cell, port)] over cell inputs and the module's output ports"""
    sinks = defaultdict(list)
    for name, c in module["cells"].items():
        dirs = c.get("port_directions", {})
        for port, bits in c["connections"].items():
            if dirs.get(port) == "input":
                for b in bits:
                    if isinstance(b, int):
                        sinks[b].append((name, port))
    for pname, p in module["ports"].items():
        if p["direction"] != "input":
            for b in p["bits"]:
                if isinstance(b, int):
                    sinks[b].append(("$port", pname))
    return sinks


def pack(src, dst, top):
    with open(src) as f:
        netlist = json.load(f)
    module = netlist["modules"][top]
    cells = module["cells"]

    def bit_sinks():
        return sinks_of(module)

    def drivers():
        drv = {}
        for name, c in cells.items():
            dirs = c.get("port_directions", {})
            for port, bits in c["connections"].items():
                if dirs.get(port) == "output":
                    for b in bits:
                        if isinstance(b, int):
                            drv[b] = (name, port)
        return drv

    def plain_ff(name, allow_enable):
        """a flip-flop with no set/reset; returns (clock bit, enable bit or '1') or None"""
        c = cells.get(name)
        if c is None or c["type"] != "TRELLIS_FF":
            return None
        p, k = c["parameters"], c["connections"]
        if k.get("LSR", ["0"])[0] != "0":
            return None
        if p.get("CLKMUX", "CLK").strip() != "CLK":
            return None
        ce_mux = p.get("CEMUX", "1").strip()
        ce = "1" if ce_mux == "1" else k.get("CE", ["1"])[0]
        if ce != "1" and not allow_enable:
            return None
        # an enable active low: ("INV", net), which a block's enable pin takes through an inverter
        return k["CLK"][0], ("INV", ce) if ce_mux == "INV" else ce

    def lut_implies(net, implied):
        """`net` is driven by a LUT4 with `implied` on an input, whose output is 1 only where that input is 1"""
        d = drv.get(net) if isinstance(net, int) else None
        if d is None or cells[d[0]]["type"] != "LUT4" or d[1] != "Z":
            return False
        c = cells[d[0]]
        init = c["parameters"]["INIT"]
        bits = [int(ch) for ch in reversed(init)] if len(init) == 16 else [(int(init, 0) >> i) & 1 for i in range(16)]
        pins = [i for i, pin in enumerate("ABCD") if c["connections"].get(pin, ["0"])[0] == implied]
        return bool(pins) and all(not bits[i] or any((i >> p) & 1 for p in pins) for i in range(16))

    def input_ff(name):
        """a flip-flop a multiplier's input register can take: `plain_ff` with an enable, one with no enable and a
        synchronous set or reset (yosys folds a constant table's entries into the flip-flop that way), or one whose
        synchronous set or reset acts only with its enable (the reset a LUT of the enable); returns (clock, enable,
        None or (reset net, value)) or None"""
        info = plain_ff(name, allow_enable=True)
        if info is not None:
            return info[0], info[1], None
        c = cells.get(name)
        if c is None or c["type"] != "TRELLIS_FF":
            return None
        p, k = c["parameters"], c["connections"]
        if p.get("SRMODE", "LSR_OVER_CE").strip() != "LSR_OVER_CE" or p.get("LSRMUX", "LSR").strip() != "LSR":
            return None
        if p.get("CLKMUX", "CLK").strip() != "CLK":
            return None
        value = 1 if p.get("REGSET", "RESET").strip() == "SET" else 0
        lsr, ce = k.get("LSR", ["0"])[0], k.get("CE", ["1"])[0]
        if p.get("CEMUX", "1").strip() == "1" or ce == "1":
            # no enable: the next value is the reset's while it is on, DI otherwise, exactly what a LUT before a
            # plain register gives
            return k["CLK"][0], "1", (lsr, value)
        if p.get("CEMUX", "1").strip() != "CE":
            return None
        if not lut_implies(lsr, ce):
            return None
        return k["CLK"][0], ce, (lsr, value)

    folded = {}

    def folded_input(ff, reset):
        """the D input of flip-flop `ff` with its synchronous set or reset `reset` folded in, through a LUT (as Quartus
        would feed a multiplier's input register, which has none): DI, or the reset's value while the reset is on"""
        if ff in folded:
            return folded[ff]
        net, value = reset
        out = next_bit[0]
        next_bit[0] += 1
        folded[ff] = out
        # Z = B ? value : A, for every C, D
        init = "".join(str(value if (i >> 1) & 1 else i & 1) for i in reversed(range(16)))
        cells[f"orb_reset_fold_{out}"] = {
            "hide_name": 0, "type": "LUT4", "parameters": {"INIT": init}, "attributes": {},
            "port_directions": {"A": "input", "B": "input", "C": "input", "D": "input", "Z": "output"},
            "connections": {"A": cells[ff]["connections"]["DI"], "B": [net], "C": ["0"], "D": ["0"], "Z": [out]}}
        packed["mult_resets_folded"] += 1
        return out

    def registers_behind(outputs, clock, allow_enable):
        """the flip-flops that `outputs` (pin, bit) each feed alone: same clock (`clock`, or the first one's when
        None), no reset, one common enable; returns (clock, enable, [(pin, flip-flop)]) or None"""
        found, enable = [], None
        for pin, b in outputs:
            s = sinks[b]
            if len(s) != 1 or s[0][1] != "DI":
                return None
            info = plain_ff(s[0][0], allow_enable)
            if info is None or (clock is not None and info[0] != clock) or (enable is not None and info[1] != enable):
                return None
            clock, enable = info
            found.append((pin, s[0][0]))
        return clock, enable, found

    next_bit = [1 + max((b for c in cells.values() for bits in c["connections"].values() for b in bits
                         if isinstance(b, int)), default=1)]

    inverted = {}

    def inverter(net):
        """a LUT that inverts `net` (as Quartus inverts an active-low enable into a block's enable); its output net"""
        if net in inverted:
            return inverted[net]
        out = next_bit[0]
        inverted[net] = out
        next_bit[0] += 1
        cells[f"orb_inverter_{out}"] = {
            "hide_name": 0, "type": "LUT4", "parameters": {"INIT": "0101010101010101"}, "attributes": {},
            "port_directions": {"A": "input", "B": "input", "C": "input", "D": "input", "Z": "output"},
            "connections": {"A": [net], "B": ["0"], "C": ["0"], "D": ["0"], "Z": [out]}}
        packed["inverted_enables"] += 1
        return out

    packed = {"ram_ports": 0, "ram_ffs": 0, "mult_inputs": 0, "mult_constant_inputs": 0, "mult_outputs": 0, "mult_ffs": 0,
              "mult_constant_pins": 0, "inverted_enables": 0, "mult_resets_folded": 0}

    # ---- RAM output registers ----
    sinks = bit_sinks()
    for name, c in list(cells.items()):
        if c["type"] != "DP16KD":
            continue
        for x in ("A", "B"):
            if c["parameters"].get(f"REGMODE_{x}", "NOREG") != "NOREG":
                continue
            clk = c["connections"][f"CLK{x}"][0]
            outs = [(f"DO{x}{i}", c["connections"].get(f"DO{x}{i}", ["x"])[0]) for i in range(18)]
            used = [(pin, b) for pin, b in outs if isinstance(b, int) and sinks.get(b)]
            if not used:
                continue
            behind = registers_behind(used, clk, allow_enable=True)
            if behind is None:
                continue
            _, enable, ffs = behind
            if isinstance(enable, tuple):
                enable = inverter(enable[1])
            c["parameters"][f"REGMODE_{x}"] = "OUTREG"
            c["connections"][f"OCE{x}"] = [enable]
            for pin, ff in ffs:
                c["connections"][pin] = cells[ff]["connections"]["Q"]
                del cells[ff]
            packed["ram_ports"] += 1
            packed["ram_ffs"] += len(ffs)

    # ---- multiplier registers ----
    sinks = bit_sinks()
    drv = drivers()
    mults = [n for n, c in cells.items() if c["type"] == "MULT18X18D"]
    absorbed_inputs = set()  # flip-flops whose Q now only feeds registered multiplier inputs
    for name in mults:
        c = cells[name]
        k, p = c["connections"], c["parameters"]
        clock = None
        enables = []  # clock-enable nets, in the order of the block's CE0..CE3 pins

        def ce_pin(enable):
            """the block's CE pin for `enable` (a net bit, or '1'), or None when all four are taken"""
            if enable not in enables:
                if len(enables) == 4:
                    return None
                enables.append(enable)
            return f"CE{enables.index(enable)}"

        # inputs: every non-constant bit from a flip-flop with no reset that feeds only multiplier inputs, one clock
        # and one enable for the input
        for x in ("A", "B"):
            if p.get(f"REG_INPUT{x}_CLK", "NONE") != "NONE":
                continue
            pins = [f"{x}{i}" for i in range(18)]
            ffs, ok, enable = {}, True, None
            for pin in pins:
                b = k.get(pin, ["0"])[0]
                if not isinstance(b, int):
                    continue
                d = drv.get(b)
                if d is None or d[1] != "Q":
                    ok = False
                    break
                info = input_ff(d[0])
                if info is None or (clock is not None and info[0] != clock) or (enable is not None and info[1] != enable):
                    ok = False
                    break
                if any(cells[s[0]]["type"] != "MULT18X18D" if s[0] in cells else True for s in sinks[b]):
                    ok = False
                    break
                clock, enable, reset = info
                ffs[pin] = (d[0], reset)
            if not ok or not ffs:
                continue
            ce = ce_pin(enable)
            if ce is None:
                continue
            p[f"REG_INPUT{x}_CLK"] = "CLK0"
            p[f"REG_INPUT{x}_CE"] = ce
            p[f"REG_INPUT{x}_RST"] = "RST0"
            for pin, (ff, reset) in ffs.items():
                k[pin] = [folded_input(ff, reset)] if reset is not None else cells[ff]["connections"]["DI"]
                absorbed_inputs.add(ff)
            packed["mult_inputs"] += 1
        # an input of constants only (a product by a constant table entry) is the same constant through a register:
        # registered with the other input, so that the block is not timed as if neither were (mixed modes)
        for x, other in (("A", "B"), ("B", "A")):
            constant = all(not isinstance(k.get(f"{x}{i}", ["0"])[0], int) for i in range(18))
            if constant and p.get(f"REG_INPUT{x}_CLK", "NONE") == "NONE" and p.get(f"REG_INPUT{other}_CLK", "NONE") != "NONE":
                p[f"REG_INPUT{x}_CLK"] = p[f"REG_INPUT{other}_CLK"]
                p[f"REG_INPUT{x}_CE"] = p[f"REG_INPUT{other}_CE"]
                p[f"REG_INPUT{x}_RST"] = p[f"REG_INPUT{other}_RST"]
                packed["mult_constant_inputs"] += 1
        # output
        if p.get("REG_OUTPUT_CLK", "NONE") == "NONE":
            used = [(f"P{i}", k.get(f"P{i}", ["x"])[0]) for i in range(36)]
            used = [(pin, b) for pin, b in used if isinstance(b, int) and sinks.get(b)]
            behind = registers_behind(used, clock, allow_enable=True) if used else None
            ce = ce_pin(behind[1]) if behind is not None else None
            if ce is not None:
                clock, _, ffs = behind
                p["REG_OUTPUT_CLK"] = "CLK0"
                p["REG_OUTPUT_CE"] = ce
                p["REG_OUTPUT_RST"] = "RST0"
                for pin, ff in ffs:
                    k[pin] = cells[ff]["connections"]["Q"]
                    del cells[ff]
                    packed["mult_ffs"] += 1
                packed["mult_outputs"] += 1
        if clock is not None:
            k["CLK0"] = [clock]
            for i, enable in enumerate(enables):
                k[f"CE{i}"] = [inverter(enable[1]) if isinstance(enable, tuple) else enable]
            c.setdefault("port_directions", {}).update({"CLK0": "input"})
            c["port_directions"].update({f"CE{i}": "input" for i in range(len(enables))})
    # Constant control pins of a multiplier are configuration on Cyclone II (and tie-offs inside the ECP5 block), not
    # signals: nextpnr would route every one from a single constant LUT into the DSP rows.
    for name in mults:
        k = cells[name]["connections"]
        for pin in [p for p in k if p.startswith(("SIGNED", "SOURCE", "RST", "CE", "CLK"))]:
            if k[pin][0] in ("0", "1", "x"):
                del k[pin]
                packed["mult_constant_pins"] += 1
    # input flip-flops that nothing but registered multiplier inputs read any more
    sinks = bit_sinks()
    for ff in absorbed_inputs:
        q = cells[ff]["connections"]["Q"][0]
        if not sinks.get(q):
            del cells[ff]
            packed["mult_ffs"] += 1

    with open(dst, "w") as f:
        json.dump(netlist, f)
    print(" ".join(f"{k}={v}" for k, v in packed.items()))


def path(report_file, netlist_file):
    with open(report_file) as f:
        report = json.load(f)
    with open(netlist_file) as f:
        netlist = json.load(f)
    top = next(n for n, m in netlist["modules"].items() if m.get("attributes", {}).get("top"))
    module = netlist["modules"][top]
    sinks = sinks_of(module)
    bit_of = {}
    for name, n in module["netnames"].items():
        for i, b in enumerate(n["bits"]):
            if isinstance(b, int):
                bit_of[f"{name}[{i}]"] = b
                if len(n["bits"]) == 1:
                    bit_of[name] = b
    cell_q = {}
    names_of_bit = defaultdict(list)
    for name, n in module["netnames"].items():
        for i, b in enumerate(n["bits"]):
            if isinstance(b, int):
                names_of_bit[b].append(name if len(n["bits"]) == 1 else f"{name}[{i}]")
    for name, c in module["cells"].items():
        if "Q" in c["connections"] and isinstance(c["connections"]["Q"][0], int):
            cell_q[name] = c["connections"]["Q"][0]
    paths = report.get("critical_paths", [])
    if not paths:
        print(json.dumps({}))
        return
    cp = max(paths, key=lambda p: sum(s["delay"] for s in p["path"]))
    steps = cp["path"]
    nets = [s for s in steps if s["type"] == "routing"]
    logic = [s for s in steps if s["type"] == "logic"]
    # a carry chain counts once: skip logic steps that leave through a carry output into the next carry input
    levels = sum(1 for s in logic if not s["from"]["port"].startswith("FCI"))
    fanouts = [(len(sinks.get(bit_of.get(s["net"], -1), [])), s["net"]) for s in nets]
    worst = max(fanouts) if fanouts else (0, "")
    sink_cell = steps[-1]["to"]["cell"]
    sink = sink_cell
    if sink_cell in cell_q:
        named = [n for n in names_of_bit[cell_q[sink_cell]] if not n.startswith("$")]
        if named:
            sink = min(named, key=len)
    lines = []
    for s in nets:
        for src in s.get("sources", []):
            if not src.startswith("/") and src not in lines:
                lines.append(src)
    print(json.dumps({
        "from": nets[0]["net"] if nets else steps[0]["from"]["cell"],
        "to": sink,
        "delay_ns": round(sum(s["delay"] for s in steps), 3),
        "logic_ns": round(sum(s["delay"] for s in steps if s["type"] != "routing"), 3),
        "routing_ns": round(sum(s["delay"] for s in nets), 3),
        "levels": levels,
        "max_fanout": worst[0],
        "max_fanout_net": worst[1],
        "rtl_lines": lines[:12],
    }))


def les(generic_file):
    with open(generic_file) as f:
        netlist = json.load(f)
    for name, module in netlist["modules"].items():
        if module.get("attributes", {}).get("blackbox"):
            continue
        feeder = {}  # net bit -> cell that can host a flip-flop fed by it
        for cname, c in module["cells"].items():
            out = {"$lut": "Y", "ORB_CARRY": "s"}.get(c["type"])
            if out:
                for b in c["connections"].get(out, []):
                    if isinstance(b, int):
                        feeder[b] = cname
        sinks = sinks_of(module)
        ram_bits = set()
        for cname, c in module["cells"].items():
            if c["type"].startswith("$mem"):
                ram_bits.update(b for b in c["connections"].get("RD_DATA", []) if isinstance(b, int))
        mul_bits = set()
        for cname, c in module["cells"].items():
            if c["type"].startswith("ORB_MUL"):
                mul_bits.update(b for port, bits in c["connections"].items()
                                if c.get("port_directions", {}).get(port) == "output" for b in bits if isinstance(b, int))
        claimed, alone = set(), 0
        for cname, c in module["cells"].items():
            if c["type"].startswith("$_DFF") or c["type"].startswith("$_SDFF") or c["type"].startswith("$_DLATCH"):
                d = c["connections"].get("D", ["x"])[0]
                q = c["connections"].get("Q", ["x"])[0]
                host = feeder.get(d) if isinstance(d, int) else None
                q_sinks = sinks.get(q, []) if isinstance(q, int) else []
                if isinstance(d, int) and d in ram_bits and len(sinks.get(d, [])) == 1:
                    continue  # the M4K's output register
                if q_sinks and all(module["cells"].get(s, {}).get("type", "").startswith("ORB_MUL") for s, _ in q_sinks):
                    continue  # the multiplier's input register
                if isinstance(d, int) and d in mul_bits and len(sinks.get(d, [])) == 1:
                    continue  # the multiplier's output register
                if host is not None and host not in claimed:
                    claimed.add(host)
                else:
                    alone += 1
        print(name, alone)


def parse_sdf(sdf_file):
    """nextpnr's SDF -> (arcs: pin -> [(pin, ns)], launch: output pin -> clock-to-out, setup: input pin -> setup,
    cell types); a pin is (instance, port)"""
    arcs, launch, setup, types = defaultdict(list), {}, {}, {}
    inst, ctype = None, None
    check = re.compile(r"\(SETUPHOLD \((?:posedge|negedge) (\S+)\) \((?:posedge|negedge) \S+\) (\S+) \S+\)")

    def unescape(s):
        return s.replace("\\", "")

    def worst(*values):
        return max(float(v.strip("()").split(":")[-1]) for v in values) / 1000.0

    with open(sdf_file) as f:
        for line in f:
            s = line.strip()
            if s.startswith("(CELLTYPE"):
                ctype = s.split('"')[1]
            elif s.startswith("(INSTANCE"):
                inst = unescape(s[len("(INSTANCE"):].rstrip(")").strip())
                types[inst] = ctype
            elif s.startswith("(INTERCONNECT"):
                parts = s[1:].rstrip(")").split()
                a, b = unescape(parts[1]).rsplit("/", 1), unescape(parts[2]).rsplit("/", 1)
                arcs[tuple(a)].append((tuple(b), worst(parts[3], parts[4])))
            elif s.startswith("(IOPATH"):
                parts = s[1:].rstrip(")").split()
                d = worst(parts[3], parts[4])
                if parts[1].startswith("CLK"):
                    launch[(inst, parts[2])] = max(launch.get((inst, parts[2]), 0.0), d)
                else:
                    arcs[(inst, parts[1])].append(((inst, parts[2]), d))
            elif s.startswith("(SETUPHOLD"):
                m = check.match(s)
                if m:
                    pin = (inst, m.group(1))
                    setup[pin] = max(setup.get(pin, 0.0), worst(m.group(2)))
    return arcs, launch, setup, types


def slack(sdf_file, netlist_file, period, groups_shown=40):
    period, groups_shown = float(period), int(groups_shown)
    arcs, launch, setup, types = parse_sdf(sdf_file)
    indeg = defaultdict(int)
    for u, vs in arcs.items():
        for v, _ in vs:
            indeg[v] += 1
    arrival, pred = dict(launch), {}
    ready = [u for u in set(arcs) | set(launch) if indeg[u] == 0]
    while ready:
        u = ready.pop()
        for v, d in arcs.get(u, []):
            if u in arrival and arrival[u] + d > arrival.get(v, -1.0):
                arrival[v], pred[v] = arrival[u] + d, u
            indeg[v] -= 1
            if indeg[v] == 0:
                ready.append(v)
    with open(netlist_file) as f:
        netlist = json.load(f)
    top = next(m for m in netlist["modules"].values() if m.get("attributes", {}).get("top"))
    names = defaultdict(list)
    for name, n in top["netnames"].items():
        for b in n["bits"]:
            if isinstance(b, int):
                names[b].append(name)

    def register(cell):
        """the register (its kept net name, bit index dropped) of a flip-flop, else the cell and its type"""
        c = top["cells"].get(cell)
        if c is not None and c["type"] == "TRELLIS_FF":
            named = [n for n in names.get(c["connections"]["Q"][0], []) if not n.startswith("$")]
            if named:
                return re.sub(r"\[\d+\]$", "", min(named, key=len))
        return f"{re.sub(r'_TRELLIS_FF_Q(_[0-9]+)?$', '', cell)} ({types.get(cell, '?')})"

    def kind(name):
        """a register's name with its numbers (bits, slots, lanes, copies) as '#'"""
        return re.sub(r"\d+", "#", name)

    found, blocks = {}, defaultdict(lambda: [0.0, 0])
    failing = 0
    for pin, su in setup.items():
        if pin not in arrival or period - su - arrival[pin] >= 0:
            continue
        failing += 1
        steps = [pin]
        while steps[-1] in pred:
            steps.append(pred[steps[-1]])
        path = steps[::-1]
        src = register(path[0][0])
        dst = register(pin[0]) + ("" if types.get(pin[0]) == "TRELLIS_FF" else f".{pin[1]}")
        key = (kind(src), kind(dst))
        s = period - su - arrival[pin]
        # logic levels: arcs through a cell, a carry chain counted once (arcs entering at FCI skipped)
        levels = sum(1 for a, b in zip(path[1:], path[2:]) if a[0] == b[0] and a[1] != "FCI")
        if key not in found or s < found[key][0]:
            found[key] = [s, found.get(key, [0, 0])[1], levels, src, dst, path]
        found[key][1] += 1
        b = blocks[block(dst)]
        b[0], b[1] = min(b[0], s), b[1] + 1
    print(f"{failing} endpoints fail {period:.3f} ns ({1000 / period:.1f} MHz), in {len(found)} groups")
    print("per sink block (worst slack ns, endpoints):")
    for name, (s, count) in sorted(blocks.items(), key=lambda kv: kv[1][0]):
        print(f"  {s:7.2f} {count:6d}  {name}")
    print("groups, worst first (worst slack ns, endpoints, logic levels, source -> sink of the worst, as registers "
          "with numbers as #):")
    ranked = sorted(found.values(), key=lambda v: v[0])
    for s, count, levels, src, dst, _ in ranked[:groups_shown]:
        print(f"{s:7.2f} {count:6d} {levels:3d}  {src} -> {dst}")
    print(f"the worst paths of the first {min(groups_shown, len(ranked))} groups, through (cell, port: arrival ns):")
    for s, count, levels, src, dst, path in ranked[:groups_shown]:
        hops = [f"{register(c) if types.get(c) == 'TRELLIS_FF' else c}.{p}:{arrival.get((c, p), 0):.2f}"
                for c, p in path if p not in ("FCI", "FCO")]
        print(f"{s:7.2f}  " + "  ".join(hops))


def congestion(prefix):
    best = None
    for name in glob.glob(glob.escape(prefix) + "_congestion_by_net_*.csv"):
        iteration = int(re.search(r"_(\d+)\.csv$", name).group(1))
        per_block = defaultdict(int)
        with open(name) as f:
            for line in f:
                net, _, count = line.strip().rpartition(",")
                if net and count.isdigit():
                    per_block[block(net)] += int(count)
        total = sum(per_block.values())
        if total and (best is None or (total, iteration) < (best[0], best[1])):
            best = (total, iteration, per_block)
    if best is None:
        print("no overused wire in the heat maps")
        return
    total, iteration, per_block = best
    shares = sorted(per_block.items(), key=lambda kv: -kv[1])
    shown = [f"{b} {100.0 * n / total:.0f} %" for b, n in shares if 100.0 * n / total >= 1][:6]
    print(f"congested: " + ", ".join(shown) + f" of the nets on overused wires (iteration {iteration})")


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "pack":
        pack(*sys.argv[2:5])
    elif len(sys.argv) == 3 and sys.argv[1] == "les":
        les(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "path":
        path(*sys.argv[2:4])
    elif len(sys.argv) in (5, 6) and sys.argv[1] == "slack":
        slack(*sys.argv[2:])
    elif len(sys.argv) == 3 and sys.argv[1] == "congestion":
        congestion(sys.argv[2])
    else:
        sys.exit(__doc__)
