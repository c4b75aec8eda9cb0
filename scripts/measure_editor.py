#!/usr/bin/env python3
"""Measures the editor window as a user meets it (docs/editor.md, "Responsiveness").

Under an X server (Xvfb is started on :99 unless DISPLAY is set), on the built-in scene at the
default window size, with the default grid:

1. waits for the first full-quality picture;
2. drags across the viewport for 3 s (xdotool), taking a screenshot of the viewport every 0.1 s (XGetImage, or xwd), and counts
   the distinct viewport pictures the screenshots saw;
3. reads the UI frame times during the drag and the time from the end of the drag to the
   full-quality frame from the editor's trace (EPIVOX_EDITOR_TRACE);
4. saves a tinted composite.wgsl into the watched shader folder (a copy), with no input, and
   times the save to the new picture on screen; then a broken save (to the error on screen) and
   the fix (to the error gone and the new picture).

Needs: xdotool and xwd (Debian: `apt-get install xdotool x11-apps`), Xvfb, a built binary.

    scripts/measure_editor.py [--bin target/debug/epivox] [--shared-device] [--json out.json]

Prints a JSON summary. Timings depend on the machine and its load; the script measures, it asserts
nothing.
"""

import argparse
import ctypes
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import threading
import time


def sh(*args, **kw):
    return subprocess.run(args, check=True, capture_output=True, **kw).stdout


def read_trace(path):
    lines = []
    try:
        with open(path) as f:
            for line in f:
                try:
                    lines.append(json.loads(line))
                except json.JSONDecodeError:
                    pass  # a line being written
    except FileNotFoundError:
        pass
    return lines


def frames(trace):
    return [l for l in trace if "ui_ms" in l]


def wait_for(trace_path, pred, timeout, what):
    t0 = time.time()
    while time.time() - t0 < timeout:
        for line in frames(read_trace(trace_path)):
            if pred(line):
                return line
        time.sleep(0.05)
    raise SystemExit(f"timed out after {timeout} s waiting for {what}")


def settled(l):
    return l["shown_full"] and l["shown"] == l["latest"] and not l["in_flight"] and not l["compiling"]


def xwd_crop(data, rect):
    """The pixels of `rect` (x, y, w, h) in an xwd dump, as bytes BGRX (32 bits per pixel)."""
    header = struct.unpack(">25I", data[:100])
    header_size, bpp, bytes_per_line, ncolors = header[0], header[11], header[12], header[19]
    if bpp != 32:
        raise SystemExit(f"xwd: {bpp} bits per pixel; expected 32 (Xvfb -screen 0 WxHx24)")
    start = header_size + ncolors * 12
    x, y, w, h = rect
    rows = [data[start + (y + r) * bytes_per_line + x * 4: start + (y + r) * bytes_per_line + (x + w) * 4]
            for r in range(h)]
    return rows


class _XImage(ctypes.Structure):
    # The leading fields of Xlib's XImage (X11/Xlib.h), up to bits_per_pixel.
    _fields_ = [("width", ctypes.c_int), ("height", ctypes.c_int), ("xoffset", ctypes.c_int),
                ("format", ctypes.c_int), ("data", ctypes.c_void_p), ("byte_order", ctypes.c_int),
                ("bitmap_unit", ctypes.c_int), ("bitmap_bit_order", ctypes.c_int), ("bitmap_pad", ctypes.c_int),
                ("depth", ctypes.c_int), ("bytes_per_line", ctypes.c_int), ("bits_per_pixel", ctypes.c_int)]


class XGrab:
    """Reads one rectangle of the screen with XGetImage (libX11 through ctypes), in this process.

    The screenshots are the measurement's own load on the machine it measures: an `xwd` process
    dumping the whole screen ten times a second took about 14% of two cores. Reading only the
    viewport's rectangle over one connection costs a fraction of that. Falls back to xwd when
    libX11 cannot be loaded."""

    def __init__(self, display):
        self.x = ctypes.cdll.LoadLibrary("libX11.so.6")
        self.x.XOpenDisplay.restype = ctypes.c_void_p
        self.x.XOpenDisplay.argtypes = [ctypes.c_char_p]
        self.x.XDefaultRootWindow.restype = ctypes.c_ulong
        self.x.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
        self.x.XGetImage.restype = ctypes.POINTER(_XImage)
        self.x.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_int,
                                     ctypes.c_uint, ctypes.c_uint, ctypes.c_ulong, ctypes.c_int]
        self.x.XDestroyImage.argtypes = [ctypes.POINTER(_XImage)]
        self.dpy = self.x.XOpenDisplay(display.encode())
        if not self.dpy:
            raise OSError(f"cannot open display {display}")
        self.root = self.x.XDefaultRootWindow(self.dpy)

    def rows(self, rect):
        """The pixels of `rect` (x, y, w, h), as rows of bytes BGRX (32 bits per pixel)."""
        x, y, w, h = rect
        all_planes, z_pixmap = 0xFFFFFFFF, 2
        img = self.x.XGetImage(self.dpy, self.root, x, y, w, h, all_planes, z_pixmap)
        if not img:
            raise SystemExit("XGetImage failed")
        try:
            im = img.contents
            if im.bits_per_pixel != 32:
                raise SystemExit(f"XGetImage: {im.bits_per_pixel} bits per pixel; expected 32")
            data = ctypes.string_at(im.data, im.bytes_per_line * h)
            return [data[r * im.bytes_per_line: r * im.bytes_per_line + w * 4] for r in range(h)]
        finally:
            self.x.XDestroyImage(img)


def mean_diff(a, b, step=3):
    """Mean absolute difference per channel (0..255), on every `step`-th pixel and row."""
    total, n = 0, 0
    for ra, rb in zip(a[::step], b[::step]):
        for i in range(0, min(len(ra), len(rb)) - 3, 4 * step):
            total += abs(ra[i] - rb[i]) + abs(ra[i + 1] - rb[i + 1]) + abs(ra[i + 2] - rb[i + 2])
            n += 3
    return total / max(n, 1)


def pct(v, p):
    if not v:
        return None
    v = sorted(v)
    return v[min(len(v) - 1, int(round((len(v) - 1) * p)))]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="target/debug/epivox")
    ap.add_argument("--shared-device", action="store_true", help="render on the window's device (to compare)")
    ap.add_argument("--drag-seconds", type=float, default=3.0)
    ap.add_argument("--json", help="also write the summary here")
    ap.add_argument("--keep", help="keep the trace and screenshots in this folder")
    ap.add_argument("--no-screenshots", action="store_true",
                    help="drag without the screenshots (they load the machine too): the UI "
                         "frame times without the measurement's own load; no picture count")
    args = ap.parse_args()
    for tool in ("xdotool", "xwd"):
        if not shutil.which(tool):
            raise SystemExit(f"{tool} is missing (Debian: apt-get install xdotool x11-apps)")

    work = tempfile.mkdtemp(prefix="epivox-measure-")
    env = dict(os.environ)
    env.pop("WAYLAND_DISPLAY", None)
    xvfb = None
    if not env.get("DISPLAY"):
        env["DISPLAY"] = ":99"
        xvfb = subprocess.Popen(["Xvfb", ":99", "-screen", "0", "1600x1000x24", "-nolisten", "tcp"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(1.0)
    shaders = os.path.join(work, "shaders")
    shutil.copytree(os.path.join(os.path.dirname(__file__), "..", "shaders"), shaders)
    trace = os.path.join(work, "trace.jsonl")
    env["EPIVOX_EDITOR_TRACE"] = trace
    env["EPIVOX_CONFIG_DIR"] = os.path.join(work, "config")
    if args.shared_device:
        env["EPIVOX_EDITOR_SHARED_DEVICE"] = "1"
    log = open(os.path.join(work, "editor.log"), "w")
    editor = subprocess.Popen([args.bin, "edit", "--shader-dir", shaders], env=env, stdout=log, stderr=log)
    out = {"shared_device": args.shared_device}
    try:
        t_start = time.time()
        first = wait_for(trace, lambda l: l["shown"] is not None, 300, "the first picture")
        out["start_to_first_picture_s"] = round(first["t"] - t_start, 2)
        full = wait_for(trace, settled, 600, "the first full-quality picture")
        out["start_to_full_quality_s"] = round(full["t"] - t_start, 2)
        adapter = [l["started"] for l in read_trace(trace) if "started" in l]
        out["adapter"] = adapter[0] if adapter else None
        xenv = {**env}
        wid = sh("xdotool", "search", "--sync", "--name", "epivox", env=xenv).split()[0].decode()
        geo = sh("xdotool", "getwindowgeometry", "--shell", wid, env=xenv).decode()
        g = dict(kv.split("=") for kv in geo.split())
        wx, wy = int(g["X"]), int(g["Y"])
        vx, vy, vw, vh = full["viewport_px"]
        rect = (wx + vx + 4, wy + vy + 4, vw - 8, vh - 8)
        out["viewport_px"] = [vw, vh]
        time.sleep(1.0)
        # One xdotool reading commands from a pipe: a process per move would limit the input to
        # what spawning allows (about 20 moves a second here).
        xdo = subprocess.Popen(["xdotool", "-"], stdin=subprocess.PIPE, text=True, env=xenv)

        def xdo_cmd(line):
            xdo.stdin.write(line + "\n")
            xdo.stdin.flush()

        # --- baseline: the pointer moving over the side panels (hover highlights repaint the
        # window), nothing rendering: what a UI frame costs on this machine by itself
        t_a = time.time()
        while time.time() - t_a < 2.0:
            f = (time.time() - t_a) / 2.0
            xdo_cmd(f"mousemove {wx + 60 + int(200 * f)} {wy + 150 + int(400 * f)}")
            time.sleep(0.016)
        t_b = time.time()
        idle = [l for l in frames(read_trace(trace)) if t_a <= l["t"] <= t_b]
        out["idle_ui_frames"] = len(idle)
        out["idle_ui_frame_gap_ms"] = {"p50": pct([l["gap_ms"] for l in idle], 0.5),
                                       "p95": pct([l["gap_ms"] for l in idle], 0.95)}
        out["idle_ui_ms_in_editor"] = {"p50": pct([l["ui_ms"] for l in idle], 0.5),
                                       "p95": pct([l["ui_ms"] for l in idle], 0.95)}
        time.sleep(0.5)

        # --- the drag, with screenshots every 0.1 s
        shots = []
        stop = threading.Event()

        try:
            grab = XGrab(xenv["DISPLAY"]).rows
        except OSError:
            grab = lambda r: xwd_crop(sh("xwd", "-root", "-silent", env=xenv), r)

        def shoot():
            t0 = time.time()
            k = 0
            while not stop.is_set() and not args.no_screenshots:
                k += 1
                shots.append((time.time(), grab(rect)))
                time.sleep(max(0.0, t0 + k * 0.1 - time.time()))

        cx, cy = rect[0] + rect[2] * 0.3, rect[1] + rect[3] * 0.6
        span = rect[2] * 0.4
        xdo_cmd(f"mousemove {int(cx)} {int(cy)}")
        time.sleep(0.3)
        shooter = threading.Thread(target=shoot)
        shooter.start()
        time.sleep(0.15)
        xdo_cmd("mousedown 1")
        t_down = time.time()
        while time.time() - t_down < args.drag_seconds:
            f = (time.time() - t_down) / args.drag_seconds
            x = cx + span * (0.5 - abs(0.5 - f)) * 2  # out and back
            xdo_cmd(f"mousemove {int(x)} {int(cy + 20 * f)}")
            time.sleep(0.016)
        xdo_cmd("mouseup 1")
        t_up = time.time()
        time.sleep(0.15)
        stop.set()
        shooter.join()

        during = [s for s in shots if t_down <= s[0] <= t_up]
        changes = [mean_diff(a[1], b[1]) for a, b in zip(during, during[1:])]
        out["screenshots_during_drag"] = len(during)
        out["distinct_viewport_pictures"] = None if args.no_screenshots else 1 + sum(1 for d in changes if d > 0.5)
        tr = frames(read_trace(trace))
        drag = [l for l in tr if t_down <= l["t"] <= t_up]
        out["ui_frames_during_drag"] = len(drag)
        # The first frame of the drag follows the still pointer before the press (nothing to
        # repaint then): its gap is that pause, not a UI frame. Gaps count from the press on.
        gaps = [l["gap_ms"] for l in drag if l["t"] - l["gap_ms"] / 1000.0 >= t_down]
        uims = [l["ui_ms"] for l in drag]
        out["ui_frame_gap_ms"] = {"p50": pct(gaps, 0.5), "p95": pct(gaps, 0.95), "max": max(gaps, default=None)}
        out["ui_ms_in_editor"] = {"p50": pct(uims, 0.5), "p95": pct(uims, 0.95), "max": max(uims, default=None)}
        out["pictures_shown_during_drag"] = len({l["shown"] for l in drag})
        pics = [l for l in read_trace(trace) if "picture" in l and t_down <= l["t"] <= t_up]
        out["previews_delivered_during_drag"] = sum(1 for p in pics if not p["full"])
        out["preview_total_ms"] = {"p50": pct([p["total_ms"] for p in pics], 0.5),
                                   "max": max([p["total_ms"] for p in pics], default=None)}
        out["preview_sizes"] = sorted({f'{p["size"][0]}x{p["size"][1]} grid {p["grid"]}' for p in pics})
        end = wait_for(trace, lambda l: l["t"] > t_up and settled(l), 600, "the full frame after the drag")
        out["drag_end_to_full_quality_s"] = round(end["t"] - t_up, 2)
        time.sleep(1.0)

        # --- shader saves with no input
        comp = os.path.join(shaders, "composite.wgsl")
        good = open(comp).read()
        at = good.rfind("textureStore(hdr, p, vec4f(c, 1.0));")
        if at < 0:
            out["shader_save"] = "composite.wgsl has changed: update the tint in scripts/measure_editor.py"
        else:
            e0 = frames(read_trace(trace))[-1]["epoch"]
            t_save = time.time()
            with open(comp, "w") as f:
                f.write(good.replace("vec4f(c, 1.0)", "vec4f(c * vec3f(1.0, 0.3, 0.3), 1.0)"))
            new = wait_for(trace, lambda l: l["t"] > t_save and l["epoch"] > e0 and l["shown"] is not None
                           and l["shown"] >= l["latest"], 120, "the tinted picture")
            fullq = wait_for(trace, lambda l: l["t"] > t_save and l["epoch"] > e0 and settled(l), 600,
                             "the tinted full frame")
            reload_ms = [l["reloaded"] for l in read_trace(trace) if "reloaded" in l]
            out["save_to_new_picture_s"] = round(new["t"] - t_save, 2)
            out["save_to_full_quality_s"] = round(fullq["t"] - t_save, 2)
            out["reload_compile_ms"] = reload_ms[-1] if reload_ms else None
            time.sleep(1.0)
            t_broken = time.time()
            with open(comp, "w") as f:
                f.write(good.replace("vec4f(c, 1.0)", "vec4f(c, undefined_name)"))
            err = wait_for(trace, lambda l: l["t"] > t_broken and l["shader_error"], 120, "the error")
            out["broken_save_to_error_s"] = round(err["t"] - t_broken, 2)
            time.sleep(1.0)
            e1 = frames(read_trace(trace))[-1]["epoch"]
            t_fix = time.time()
            with open(comp, "w") as f:
                f.write(good)
            fixed = wait_for(trace, lambda l: l["t"] > t_fix and not l["shader_error"] and l["epoch"] > e1
                             and l["shown"] is not None and l["shown"] >= l["latest"], 120, "the fix")
            out["fix_save_to_new_picture_s"] = round(fixed["t"] - t_fix, 2)
    finally:
        if "xdo" in locals():
            xdo.stdin.close()
            xdo.wait()
        editor.terminate()
        try:
            editor.wait(10)
        except subprocess.TimeoutExpired:
            editor.kill()
        if xvfb:
            xvfb.terminate()
        if args.keep:
            shutil.copytree(work, args.keep, dirs_exist_ok=True)
        shutil.rmtree(work, ignore_errors=True)
    text = json.dumps(out, indent=2)
    print(text)
    if args.json:
        with open(args.json, "w") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    sys.exit(main())
