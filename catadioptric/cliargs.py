"""What the subcommands of ``catadioptric`` share: the parser whose errors are one line, checked
numeric flags, the one meaning of ``--rig``, output folders, image sizes and Dask addresses.

Every error is one line, ``catadioptric: error: --flag: expected ..., got ...`` (exit code 2):
argparse's own errors through :class:`Parser`, the others as a :class:`CatadioptricError`
whose message starts with the flag (``cli.main`` prints it).
"""
from __future__ import annotations

import argparse
import math
import os
import socket
import sys

from ._checks import CatadioptricError

__all__ = ["Parser", "positive_int", "nonnegative_int", "positive_float", "nonnegative_float", "flag_error",
           "resolve_rig", "check_out_dir", "parse_resolution", "check_scheduler", "RIG_HELP",
           "CALIBRATION_RIG_HELP"]

#: The help text of every ``--rig``.
RIG_HELP = "a rig name (a packaged rig spec or preset: catadioptric.rigspec.rig_names()) or a rig spec file"
#: The help text of the ``--rig`` of the commands that take any central camera (detection, pose).
CALIBRATION_RIG_HELP = (RIG_HELP + ", or a calibration file of OpenCV omnidir (YAML/XML), Kalibr (camchain YAML) "
                        "or OCamCalib (calib_results.txt)")


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line: ``catadioptric: error: --flag: ...`` (exit 2)."""

    def error(self, message: str):
        if message.startswith("argument "):
            message = message[len("argument "):]
        self.exit(2, f"catadioptric: error: {message}\n")


# ------------------------------------------------------------------ numbers
def _number(kind, s: str, what: str, ok):
    try:
        v = kind(s)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {s!r}") from None
    if not ok(v):
        raise argparse.ArgumentTypeError(f"expected {what}, got {s!r}")
    return v


def positive_int(s: str) -> int:
    """argparse type: an integer >= 1."""
    return _number(int, s, "a positive integer", lambda v: v >= 1)


def nonnegative_int(s: str) -> int:
    """argparse type: an integer >= 0."""
    return _number(int, s, "an integer >= 0", lambda v: v >= 0)


def positive_float(s: str) -> float:
    """argparse type: a finite number > 0."""
    return _number(float, s, "a positive number", lambda v: math.isfinite(v) and v > 0)


def nonnegative_float(s: str) -> float:
    """argparse type: a finite number >= 0."""
    return _number(float, s, "a number >= 0", lambda v: math.isfinite(v) and v >= 0)


# ------------------------------------------------------------------ errors
def flag_error(flag: str, exc, param: str | None = None) -> CatadioptricError:
    """A :class:`CatadioptricError` about the command-line flag ``flag``. A library message that
    starts with the Python parameter ``param`` (``"path_or_name: ..."``) is re-addressed to the flag."""
    msg = str(exc)
    if param and msg.startswith(param + ":"):
        msg = msg[len(param) + 1:].lstrip()
    return CatadioptricError(f"{flag}: {msg}")


# ------------------------------------------------------------------ --rig
def resolve_rig(value: str, *, width: int | None = None, height: int | None = None, flag: str = "--rig",
                camera: str | None = None, calibrations: bool = False):
    """The camera of a ``--rig`` value and its description ``{"name", "spec"}``. The value is a rig
    name (a packaged rig spec file or a preset of ``catadioptric.rigs``) or a rig spec file (TOML
    or JSON), as everywhere (``load_rig``; ``spec``: the normalised rig spec), or a calibration
    file of OpenCV omnidir, Kalibr or OCamCalib (:func:`catadioptric.formats.load_camera`, recognised
    by content; ``camera``: the camera of a Kalibr camchain; ``spec``: ``{"calibration": format,
    "camera": cam.to_dict()}``), for the commands that take any central camera
    (``calibrations=True``: detection and pose; rendering, exports and the centrality figures
    need an exact rig and refuse one). A calibration fixes the image size: ``width``/``height``,
    when given (the image's), must match it."""
    from .formats import calibration_format, load_camera
    from .rigspec import load_rig, load_rig_spec, rig_from_spec

    fmt = None
    if isinstance(value, str) and os.path.isfile(value) and not value.lower().endswith((".toml", ".json")):
        try:
            fmt = calibration_format(value)
        except (OSError, CatadioptricError):
            fmt = None
    if fmt is not None:
        if not calibrations:
            raise CatadioptricError(f"{flag}: expected a rig name or a rig spec file (this command needs an exact rig: "
                                    f"a mirror and a pinhole), got the {fmt} calibration file {value!r} (calibration "
                                    f"files are taken by detect, relative-pose and absolute-pose)")
        try:
            cam = load_camera(value, camera=camera)
        except CatadioptricError as exc:
            raise flag_error(flag, exc) from None
        if width is not None and height is not None and (width, height) != (cam.width, cam.height):
            raise CatadioptricError(f"{flag}: the calibration {value!r} is of {cam.width}x{cam.height} images, got an "
                                    f"image of {width}x{height}")
        return cam, {"name": value, "spec": {"calibration": fmt, "camera": cam.to_dict()}}
    if camera is not None:
        raise CatadioptricError(f"--camera: only for a Kalibr camchain given as {flag}, got {flag} {value!r}")
    try:
        spec = load_rig_spec(value)
        if "preset" in spec:
            cam = load_rig(value, width=width, height=height)
        else:
            cam = rig_from_spec(spec, width=width, height=height)
    except CatadioptricError as exc:
        raise flag_error(flag, exc, "path_or_name") from None
    return cam, {"name": value, "spec": spec}


# ------------------------------------------------------------------ folders
def check_out_dir(value: str, flag: str = "--out") -> str:
    """Check that ``value`` names a folder the command can create or write into, before any work:
    not empty, not a file, not under a file, and writable. Returns the value."""
    if not isinstance(value, str) or not value.strip():
        raise CatadioptricError(f"{flag}: expected a folder path, got {value!r}")
    path = os.path.abspath(value)
    if os.path.exists(path) and not os.path.isdir(path):
        raise CatadioptricError(f"{flag}: expected a folder, got the file {value!r}")
    probe = path
    while not os.path.exists(probe):
        parent = os.path.dirname(probe)
        if parent == probe:
            break
        probe = parent
    if not os.path.isdir(probe):
        raise CatadioptricError(f"{flag}: expected a folder, got {value!r}, which lies under the file {probe!r}")
    if not os.access(probe, os.W_OK | os.X_OK):
        what = "folder" if probe == path else f"folder {probe!r} that would hold it"
        raise CatadioptricError(f"{flag}: expected a writable folder, got {value!r} (cannot write in the {what})")
    if probe != path:
        # make it and take it away again: a folder the system refuses (under /proc as root, a name over
        # 255 characters) is an error now, not a traceback after the work
        try:
            os.makedirs(path)
        except OSError as exc:
            raise CatadioptricError(f"{flag}: cannot create the folder {value!r} ({exc.strerror or exc})") from None
        d = path
        while d != probe:
            os.rmdir(d)
            d = os.path.dirname(d)
    return value


# ------------------------------------------------------------------ --resolution
def parse_resolution(value: str, flag: str = "--resolution") -> tuple[int, int]:
    """``(width, height)`` of a ``--resolution`` value (a preset name or WIDTHxHEIGHT, within the
    size limit of :func:`catadioptric.render.common.load_resolution`)."""
    from .render_presets import load_resolution

    try:
        return load_resolution(value)
    except CatadioptricError as exc:
        raise flag_error(flag, exc, "resolution") from None


# ------------------------------------------------------------------ --scheduler
def check_scheduler(address: str, flag: str = "--scheduler", timeout: float = 5.0) -> str:
    """Fail fast on a Dask scheduler address that cannot work: the ``dask`` extra missing, a
    host name that does not resolve, or a TCP port nobody listens on (instead of Dask's 30 s
    connection timeout). Other protocols than ``tcp``/``tls`` are left to Dask."""
    from ._extras import require

    require("distributed", f"{flag} (a Dask cluster)")
    if not isinstance(address, str) or not address.strip():
        raise CatadioptricError(f"{flag}: expected a Dask scheduler address such as tcp://127.0.0.1:8786, "
                                f"got {address!r}")
    scheme, sep, loc = address.partition("://")
    if not sep:
        scheme, loc = "tcp", address
    if scheme not in ("tcp", "tls"):
        return address
    if loc.startswith("["):  # [ipv6]:port
        host, _, rest = loc[1:].partition("]")
        port_text = rest[1:] if rest.startswith(":") else ""
    else:
        host, _, port_text = loc.rpartition(":") if ":" in loc else (loc, "", "")
    try:
        port = int(port_text) if port_text else 8786
        if not 0 < port < 65536:
            raise ValueError
    except ValueError:
        raise CatadioptricError(f"{flag}: expected a port number in 1..65535 in {address!r}, "
                                f"got {port_text!r}") from None
    if not host:
        raise CatadioptricError(f"{flag}: expected HOST:PORT (e.g. tcp://127.0.0.1:8786), got {address!r}")
    try:
        socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as exc:
        raise CatadioptricError(f"{flag}: cannot resolve the host {host!r} of {address!r} ({exc.strerror})") from None
    try:
        socket.create_connection((host, port), timeout=timeout).close()
    except OSError as exc:
        why = exc.strerror or ("timed out" if isinstance(exc, TimeoutError) else type(exc).__name__)
        raise CatadioptricError(f"{flag}: cannot reach a Dask scheduler at {address!r} ({why}; "
                                f"waited at most {timeout:g} s)") from None
    return address


def print_error(message: str) -> int:
    """Print ``catadioptric: error: <message>`` on stderr; returns the exit code 2."""
    print(f"catadioptric: error: {message}", file=sys.stderr)
    return 2
