#!/usr/bin/python3
"""The file readers through the CLI (issue 46 item 3; docs/formats.md "Limits"): every command that reads
files, given a FIFO, /dev/zero, a directory, a 3 GB sparse file, a file over `--max-input-mb` and a table
over `--max-input-rows`, ends at once with an error naming the file; given random files of the documented
formats and broken ones, answers with a result or a clear error naming the file: never a signal, never
past its time, never more memory than a bound in proportion to what it read (each run's maximum RSS from
wait4). The readers in-process against thousands of broken files: tests/formats/input_readers_property_test.cpp.
Usage: input_files_cli_test.py BUILD_DIR"""
import math
import re
import os
import random
import resource
import select
import subprocess
import sys
import tempfile
import time
import unittest

BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")


def sanitized():
    """Whether BUILD is a sanitizer build: its RSS carries the shadow memory and the allocator's quarantine."""
    try:
        with open(os.path.join(BUILD, "CMakeCache.txt")) as f:
            return any(line.startswith("GUIDEWAY_SANITIZE:") and line.strip().split("=", 1)[1] not in ("", "OFF")
                       for line in f)
    except OSError:
        return False


# A run's memory bound: a floor (the program, its libraries; under ASan the shadow and quarantine) and a
# factor of the bytes it was given (the text, a table's rows at 24 bytes, the model's vectors).
RSS_FLOOR_MB = 400 if sanitized() else 80
RSS_PER_INPUT_BYTE = 30
TIME_LIMIT_S = 60 if sanitized() else 20


def dbb_run(direction="ccw", n=120):
    t = ("# format = guideway/dbb-run/1\n# radius_mm = 100\n# height_mm = 0\n# direction = %s\n"
         "# feed_mm_per_min = 1000\n# plane = xy\n# center_a_mm = 0\n# center_b_mm = 0\nt_s,angle_deg,dL_um\n" % direction)
    sign = 1 if direction == "ccw" else -1
    for i in range(n):
        t += "%g,%g,%g\n" % (i * 0.05, sign * i * 360.0 / n, 2 * math.sin(i * 0.1) + math.cos(2 * i * 6.28 / n))
    return t


def traverse(stations=12):
    t = "# step_mm = 10\nx_mm,pitch_arcsec,yaw_arcsec,t_s,pass\n"
    for p in (1, 2):
        for i in range(stations):
            k = i if p == 1 else stations - 1 - i
            t += "%d,%g,-0.4,%d,%d\n" % (k * 10, 0.1 * k - 0.3 + 0.05 * math.sin(k), p * 100 + i, p)
    return t


def runout(revolutions=3):
    t = "# plate_diameter_mm = 1000\n# parallelism_um = 2.5\n# travel_mm = 600\n# rpm = 60\nangle_deg,runout_um\n"
    for i in range(36 * revolutions):
        t += "%d,%g\n" % (i * 10, 0.15 * math.cos(math.radians(i * 10)) + 0.01 * math.sin(i))
    return t


def profile(n=128):
    t = "# format = guideway/profile/1\n# feed_mm_per_min = 2\n# spindle_rpm = 100\nx_mm,z_um\n"
    for i in range(n):
        t += "%g,%g\n" % (i * 0.05, 0.2 * math.sin(i * 0.3))
    return t


def raw_recording():
    """A run-out session's recording (tests/golden/runout.csv, recorded live from the emulators)."""
    with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "golden", "runout.csv")) as f:
        return f.read()


NUMBERS = ["1e308", "-1e308", "nan", "inf", "1e-320", "-0", "0", "9" * 30, "1e300", "", "x"]


def mutate(text, rng):
    lines = text.split("\n")
    kind = rng.randrange(7)
    i = rng.randrange(len(lines))
    if kind == 0:
        digits = [k for k, c in enumerate(lines[i]) if c.isdigit()]
        if digits:
            a = rng.choice(digits)
            b = a
            while b < len(lines[i]) and lines[i][b] in "0123456789.e-+":
                b += 1
            lines[i] = lines[i][:a] + rng.choice(NUMBERS) + lines[i][b:]
    elif kind == 1:
        del lines[i]
    elif kind == 2:
        lines.insert(i, lines[i])
    elif kind == 3:
        lines[i] += "," * rng.randrange(1, 3000)
    elif kind == 4:
        return "".join(chr(rng.randrange(256)) for _ in range(rng.randrange(300)))
    elif kind == 5:
        return text[:rng.randrange(len(text))]
    else:  # a column scaled by 1e300
        lines = [l.replace(",", ",1e300", 1) if l[:1].isdigit() else l for l in lines]
    return "\n".join(lines)


class InputFiles(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory(prefix="gwin-")
        cls.dir = cls.tmp.name
        cls.fifo = os.path.join(cls.dir, "fifo.csv")
        os.mkfifo(cls.fifo)
        cls.sparse = os.path.join(cls.dir, "sparse.csv")
        with open(cls.sparse, "wb") as f:
            f.truncate(3 * 10 ** 9)  # 3 GB of holes: over the 2 GB bound, costs no disk
        cls.subdir = os.path.join(cls.dir, "a-directory")
        os.mkdir(cls.subdir)
        cls.big = cls.write("big.csv", traverse(stations=60000))  # 2.5 MB: over --max-input-mb 1
        cls.rows = cls.write("rows.csv", traverse(stations=400))  # 800 rows: over --max-input-rows 100
        cls.out = os.path.join(cls.dir, "out")

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    @classmethod
    def write(cls, name, text):
        path = os.path.join(cls.dir, name)
        with open(path, "w", encoding="latin-1") as f:
            f.write(text)
        return path

    def run_cli(self, *args, given_bytes=0):
        """Runs guideway; returns (exit code, stderr, seconds, max RSS in MB). A run past the time limit is
        killed and fails the test; so does a run killed by a signal or over the memory bound."""
        started = time.monotonic()
        p = subprocess.Popen([GUIDEWAY, *args], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE)
        err = b""
        while True:
            ready, _, _ = select.select([p.stderr], [], [], 0.2)
            if ready:
                chunk = os.read(p.stderr.fileno(), 1 << 16)
                err += chunk
                if chunk:
                    continue
            pid, status, usage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - started > TIME_LIMIT_S:
                p.kill()
                os.wait4(p.pid, 0)
                self.fail("guideway %s: still running after %d s (a hang)" % (" ".join(args), TIME_LIMIT_S))
        err += p.stderr.read()
        p.stderr.close()
        p.returncode = os.waitstatus_to_exitcode(status)
        seconds = time.monotonic() - started
        rss_mb = usage.ru_maxrss / 1024.0
        text = err.decode("utf-8", "replace")
        self.assertGreaterEqual(p.returncode, 0, "guideway %s: killed by signal %d\n%s" % (" ".join(args), -p.returncode, text))
        for sign in ("terminate called", "bad_alloc", "AddressSanitizer", "runtime error:", "Segmentation"):
            self.assertNotIn(sign, text, "guideway %s" % " ".join(args))
        bound = RSS_FLOOR_MB + RSS_PER_INPUT_BYTE * given_bytes / 1e6
        self.assertLess(rss_mb, bound, "guideway %s: %.0f MB resident, over %.0f MB" % (" ".join(args), rss_mb, bound))
        return p.returncode, text, seconds, rss_mb

    # Each command that reads files, with FILE where the file under test goes.
    COMMANDS = [
        ("identify", "dbb", "FILE"),
        ("identify", "straightness", "FILE"),
        ("identify", "runout", "FILE"),
        ("identify", "flatness", "--profile", "FILE", "--straightness", "FILE"),
        ("identify", "artifact", "--calibration", "FILE", "--horizontal", "FILE", "--vertical", "FILE"),
        ("identify", "unionjack", "FILE"),
        ("explain", "--model", "traverse", "FILE"),
        ("explain", "--model", "runout", "FILE"),
        ("report", "FILE", "--out", "OUT.html"),
        ("wavelet", "wavedec", "--wavelet", "db1", "--level", "2", "FILE"),
        ("correlate", "FILE", "FILE"),
        ("compensate", "dbb", "FILE", "--out-dir", "OUT"),
        ("replay", "FILE"),
    ]

    def command(self, template, path, *before):
        out = self.out + "-" + template[0]
        return [*before, *[path if a == "FILE" else out if a == "OUT" else out + ".html" if a == "OUT.html" else a
                           for a in template]]

    def refused_at_once(self, path, what, *before, commands=None):
        for template in commands or self.COMMANDS:
            args = self.command(template, path, *before)
            rc, err, seconds, _ = self.run_cli(*args)
            self.assertNotEqual(rc, 0, "guideway %s accepted %s" % (" ".join(args), what))
            self.assertIn(path, err, "guideway %s: the error does not name the file" % " ".join(args))
            self.assertLess(seconds, TIME_LIMIT_S / 2, "guideway %s took %.1f s to refuse %s" % (" ".join(args), seconds, what))

    def test_a_fifo_is_refused_not_waited_on(self):
        self.refused_at_once(self.fifo, "a FIFO")

    def test_dev_zero_is_refused_not_read(self):
        self.refused_at_once("/dev/zero", "/dev/zero", commands=[c for c in self.COMMANDS if c[1] != "unionjack"])

    def test_a_directory_is_refused(self):
        self.refused_at_once(self.subdir, "a directory",
                             commands=[c for c in self.COMMANDS if c[1] not in ("unionjack",) and c[0] != "report"])

    def test_a_file_over_the_size_bound_is_refused_before_it_is_read(self):
        self.refused_at_once(self.sparse, "3 GB", commands=self.COMMANDS[:3] + self.COMMANDS[6:8])
        rc, err, _, rss = self.run_cli("--max-input-mb", "1", "identify", "straightness", self.big)
        self.assertEqual(rc, 1)
        self.assertRegex(err, re.escape(self.big) + r": 3\.\d+ MB is over")
        self.assertIn("over the limit of 1 MB a file (guideway --max-input-mb)", err)

    def test_a_table_over_the_row_bound_stops_there(self):
        for template in self.COMMANDS[1:2] + self.COMMANDS[6:7] + self.COMMANDS[9:10]:
            rc, err, _, _ = self.run_cli("--max-input-rows", "100", *self.command(template, self.rows))
            self.assertEqual(rc, 1, err)
            self.assertIn(self.rows + ":103: more than 100 data rows", err)  # the header is line 2

    def test_standard_input_is_bounded_too(self):
        p = subprocess.run("head -c 3000000 /dev/zero | %s --max-input-mb 1 wavelet wavedec --wavelet db1 -" % GUIDEWAY,
                           shell=True, capture_output=True, text=True, timeout=TIME_LIMIT_S)
        self.assertEqual(p.returncode, 1, p.stderr)
        self.assertIn("<stdin>: more is over the limit of 1 MB", p.stderr)

    def test_random_files_give_a_result_or_a_clear_error(self):
        rng = random.Random(46)
        formats = [
            (("identify", "dbb", "FILE"), lambda: dbb_run()),
            (("identify", "straightness", "FILE"), traverse),
            (("identify", "runout", "FILE"), runout),
            (("explain", "--model", "traverse", "FILE"), lambda: traverse(stations=40)),
            (("explain", "--model", "runout", "FILE"), runout),
            (("report", "FILE", "--out", "OUT.html"), profile),
            (("wavelet", "wavedec", "--wavelet", "db1", "--level", "2", "--column", "z_um", "FILE"), profile),
            (("replay", "FILE"), raw_recording),
        ]
        results = errors = 0
        for n, (template, make) in enumerate(formats):
            valid = make()
            for k in range(6):
                text = valid if k == 0 else mutate(valid, rng)
                path = self.write("random-%d-%d.csv" % (n, k), text)
                rc, err, _, _ = self.run_cli(*self.command(template, path), given_bytes=len(text))
                if k == 0:
                    self.assertEqual(rc, 0, "guideway %s on a valid file: %s" % (" ".join(template), err))
                if rc == 0:
                    results += 1
                else:
                    errors += 1
                    self.assertIn(path, err, "guideway %s: the error does not name the file" % " ".join(template))
        self.assertGreater(errors, 10)
        self.assertGreater(results, len(formats))


if __name__ == "__main__":
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    unittest.main(verbosity=2)
