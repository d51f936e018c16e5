"""The conformance numbers for a build of the three FMUs (not a test): each conformance
case, printed as it is measured.

    python tests/conformance/numbers.py BUILD_DIR     (e.g. build)

Run from a checkout; the FMUs are driven through fmpy only (the host does not import
ballmill, so an older build runs its own bundled copy)."""
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from harness import Fmu as _Fmu  # noqa: E402
class Fmu(_Fmu):
    def get(self, n):
        return "dead" if self.dead else super().get(n)


class CrankStartup:
    def __init__(self, l=0.5, n0=60, t0=2.5):
        self.l, self.w0, self.t0 = l, 2 * math.pi * n0 / 60, t0
    def state(self, t):
        w0, t0, l = self.w0, self.t0, self.l
        if t <= t0:
            u = 1 - t / t0
            p, pd, pdd = -w0 * (t - t0) ** 3 / (3 * t0 * t0) + w0 * t - w0 * t0 / 3, w0 * (1 - u * u), 2 * w0 * u / t0
        else:
            p, pd, pdd = 2 / 3 * w0 * t0 + w0 * (t - t0), w0, 0.0
        c, s = math.cos(p), math.sin(p)
        return (l * c, l * s, -l * pd * s, l * pd * c, l * (-pdd * s - pd * pd * c), l * (pdd * c - pd * pd * s))
B = sys.argv[1]
P = lambda m: f"{B}/{m}.fmu"
law = CrankStartup(l=0.5, n0=60, t0=2.5)
INP = ("x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O")
def feed(f, t, off=0.0):
    s = law.state(t); d = dict(zip(INP, s)); d["x1O"] += off; f.set(**d)
def run(steps, mode=1, off=0.0, **par):
    f = Fmu(P("BallInShell"), "b", input_mode=mode, **par); feed(f, 0.0, off); f.init()
    t = 0.0
    for h in steps:
        st = f.step(h, t)
        if st: return f, st
        t += h; feed(f, t, off)
    return f, 0
H = 2e-3
ref, _ = run([H] * 100); Nref = ref.get("N"); xref = ref.get("xC")
for frac in (1e-3, 1e-4, 1e-6):
    f, st = run([H * frac] + [H] * 100)
    t0 = time.time(); f2, st2 = run([H*frac] + [H]*100)
    print(f"p1 tiny {frac:g}: N", '->', (f.get("N"), st, "ref", Nref, f"t={f.time:.4f}"), flush=True)
# point 1 in mode 2
r2, _ = run([H]*100, mode=2); f, st = run([H*1e-3]+[H]*100, mode=2)
print("p1 mode2 tiny 1e-3: dN", '->', f.get("N") - r2.get("N"), flush=True)
# point 2: bad steps
for h in (-1e-3, float("nan"), float("inf")):
    f, _ = run([H]*5); st = f.step(h); print(f"p2 step {h}", '->', (st, f.get("N")), flush=True)
f, _ = run([H]*5); st = f.step(H, t=0.5); print("p2 noncontiguous ball", '->', (st, f.messages()[-160:]), flush=True)
for m in ("MotorStartup", "InductionMotor"):
    f = Fmu(P(m), "d"); f.init(); f.step(1e-3); print(f"p2 {m} nan step", '->', f.step(float("nan")), flush=True)
    print(f"p2 {m} back step", '->', f.step(1e-3, t=0.0), flush=True)
    f.terminate(); print(f"p2 {m} after terminate", '->', f.step(1e-3), flush=True)
# point 3 fixed params after init
for m, par in (("BallInShell", "m"), ("MotorStartup", "l"), ("InductionMotor", "i")):
    f = Fmu(P(m), "d"); f.init(); st = f.set(**{par: 2.0}); print(f"p3 {m} set {par}", '->', (st, f.messages()[-170:]), flush=True)
# point 4 foreign state
a = Fmu(P("BallInShell"), "a", m=2.0); feed(a, 0); a.init()
b = Fmu(P("BallInShell"), "b", m=0.51); feed(b, 0); b.init()
for k in range(50):
    for f in (a, b):
        f.step(H); feed(f, f.time)
s = a.get_state(); st = b.set_state(s)
print("p4 state m=2 into m=0.51: status, m, N(b), N(a)", '->', (st, b.get("m"), b.get("N"), a.get("N")), flush=True)
# point 6 offsets & jump
base, _ = run([H]*100)
for off in (1e6, 1e10):
    f, st = run([H]*100, off=off); print(f"p6 offset {off:g}: dxC, dN, valid?", '->', (f.get("xC") - base.get("xC"), f.get("N") - base.get("N"), f.vars.get("valid") and f.get("valid")), flush=True)
f = Fmu(P("BallInShell"), "j"); feed(f, 0); f.init(); t = 0
for k in range(50):
    f.step(H, t); t += H; feed(f, t, off=1.0 if k >= 20 else 0.0)
print("p6 1 m jump: N, contact, valid", '->', (f.get("N"), f.get("contact"), f.vars.get("valid") and f.get("valid")), flush=True)
# point 7 validity
f = Fmu(P("BallInShell"), "v"); 
law2 = CrankStartup(l=0.5, n0=60, t0=0.5)
def feed2(f, t):
    f.set(**dict(zip(INP, law2.state(t))))
feed2(f, 0); f.init(); t = 0; flips = 0; last = True
while t < 2.0 - 1e-12:
    f.step(H, t); t += H; feed2(f, t); c = f.get("contact")
    flips += (c and not last); last = c
print("p7 t0=0.5: contact returns, valid, t_invalid", '->', (flips, f.vars.get("valid") and f.get("valid"), f.vars.get("t_invalid") and f.get("t_invalid")), flush=True)
# point 8 messages
for m, par, val in (("BallInShell", "delta", -1.0), ("MotorStartup", "t0", 1e-300), ("MotorStartup", "l", 1e300), ("InductionMotor", "i", 1e300)):
    f = Fmu(P(m), "e", **{par: val}); st = f.init(); print(f"p8 {m} {par}={val}", '->', (st, f.messages()[-200:]), flush=True)
# point 9
f = Fmu(P("BallInShell"), "w", wx0=1e300); st = f.init(); print("p9 wx0=1e300", '->', (st, f.messages()[-150:]), flush=True)
# point 5
f = Fmu(P("BallInShell"), "w", integrator=3, h_fixed=1e-11); st = f.init(); t0 = time.time(); st2 = f.step(1e-3) if st == 0 else None
print("p5 h_fixed=1e-11: init, step, seconds", '->', (st, st2, round(time.time() - t0, 2)), flush=True)

