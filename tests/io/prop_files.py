"""BVH files built from a real take's text with a prop (a sword) added by hand as a second ROOT, as
MotionBuilder and Blender export one beside the character: for the tests of io/bvh_roots and of the commands."""

from __future__ import annotations

from pathlib import Path

PROP = ["ROOT Sword\n", "{\n", "\tOFFSET 10.0 0.0 5.0\n",
        "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n",
        "\tJOINT Blade\n", "\t{\n", "\t\tOFFSET 0 40.5 0\n", "\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n",
        "\t\tEnd Site\n", "\t\t{\n", "\t\t\tOFFSET 0 60 0\n", "\t\t}\n", "\t}\n", "}\n"]


def prop_numbers(f: int) -> str:
    """The prop's 9 numbers on frame ``f``, written as an exporter might (mixed decimals, an exponent)."""
    return f"{f * 0.5:.3f} 101.25 -3.0E1 0.00 {f % 7}.1 -90 15 0.000001 -45.5"


def take_lines(source: Path, frames: int) -> tuple[list[str], list[str], str]:
    """``source``'s hierarchy lines (up to MOTION), its first ``frames`` motion lines and its Frame Time line."""
    lines = source.read_bytes().decode().splitlines(keepends=True)
    at = next(i for i, t in enumerate(lines) if t.strip() == "MOTION")
    return lines[:at], [t for t in lines[at + 3:] if t.strip()][:frames], lines[at + 2]


def plain(source: Path, out: Path, frames: int = 30) -> Path:
    """The take alone: ``source``'s first ``frames`` frames."""
    head, body, frame_time = take_lines(source, frames)
    out.write_bytes("".join(head + ["MOTION\n", f"Frames: {len(body)}\n", frame_time] + body).encode())
    return out


def with_prop(source: Path, out: Path, frames: int = 30, before: bool = False, comments: bool = False) -> Path:
    """``source``'s first ``frames`` frames with :data:`PROP` as a second ROOT after the character (or before
    it), its numbers on every motion line; ``comments``: comment lines before HIERARCHY, between the roots and
    between MOTION and Frames."""
    head, body, frame_time = take_lines(source, frames)
    h = next((i for i, t in enumerate(head) if t.strip() == "HIERARCHY"), -1) + 1
    note = ["# a comment between the roots\n"] if comments else []
    if before:
        hier = head[:h] + PROP + note + head[h:]
        rows = [prop_numbers(f) + " " + t.lstrip(" \t") for f, t in enumerate(body)]
    else:
        hier = head + note + PROP
        rows = [t.rstrip("\r\n") + " " + prop_numbers(f) + t[len(t.rstrip("\r\n")):] for f, t in enumerate(body)]
    pre = ["# exported with a prop\n"] if comments else []
    motion = ["MOTION\n"] + (["  # 30 frames follow\n"] if comments else []) + [f"Frames: {len(body)}\n", frame_time]
    out.write_bytes("".join(pre + hier + motion + rows).encode())
    return out
