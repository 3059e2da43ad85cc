#!/usr/bin/python3
"""The Debian package (cmake/GuidewayPackage.cmake, scripts/package.sh): CPack builds it from this build tree and
the test reads it back with dpkg-deb and lintian.

- its control fields (name, the project's version, Section, Depends with python3, systemd and the shared
  libraries dpkg-shlibdeps found, Suggests linuxcnc-uspace) and conffiles (/etc/guideway/guideway.toml);
- its files: the four programs, their man pages (compressed), the units, sysusers.d and tmpfiles.d (with
  /run/guideway-linuxcnc for the bridge's socket), the configuration, the LinuxCNC files and the loop demo,
  the virtual machines, the documentation and examples; nothing under /usr/local or of the tests;
- its maintainer scripts, run against stand-ins for systemd's tools: postinst creates the user and the
  directories on configure and reloads systemd, starts nothing; prerm stops the units on remove only;
  postrm deletes no measured data;
- the unpacked programs run (guideway --version, guidewayd --check-config on the packaged configuration);
- lintian: no error and no warning.

usage: package_test.py BUILD_DIR SOURCE_DIR
"""
import os
import re
import shutil
import stat
import subprocess
import sys
import tempfile

SKIP = 77

EXPECTED = [
    "etc/guideway/guideway.toml",
    "usr/bin/guideway", "usr/bin/guideway-emulate", "usr/bin/guideway-linuxcnc-bridge", "usr/sbin/guidewayd",
    "usr/share/man/man1/guideway.1.gz", "usr/share/man/man1/guideway-emulate.1.gz",
    "usr/share/man/man1/guideway-linuxcnc-bridge.1.gz", "usr/share/man/man8/guidewayd.8.gz",
    "usr/lib/systemd/system/guidewayd.service", "usr/lib/systemd/system/guideway-fleet.service",
    "usr/lib/sysusers.d/guideway.conf", "usr/lib/tmpfiles.d/guideway.conf",
    "usr/share/guideway/linuxcnc/guideway-bridge.hal", "usr/share/guideway/linuxcnc/guideway_headless.py",
    "usr/share/guideway/linuxcnc/linuxcnc_loop.py", "usr/share/guideway/linuxcnc/linuxcnc_demo.sh",
    "usr/share/guideway/linuxcnc/sim/guideway-sim.ini", "usr/share/guideway/linuxcnc/sim/guideway-sim.hal",
    "usr/share/guideway/machine-example.toml",
    "usr/share/doc/guideway/copyright", "usr/share/doc/guideway/changelog.gz", "usr/share/doc/guideway/linuxcnc.md",
    "usr/share/doc/guideway/examples/99-guideway-instruments.rules",
]
EXECUTABLE = ["usr/bin/guideway", "usr/sbin/guidewayd", "usr/share/guideway/linuxcnc/linuxcnc_demo.sh",
              "usr/share/guideway/linuxcnc/linuxcnc_loop.py", "usr/share/guideway/linuxcnc/guideway_headless.py"]


def run(*argv, **kw):
    return subprocess.run(argv, capture_output=True, text=True, timeout=kw.pop("timeout", 120), **kw)


def build_package(build, out):
    # gzip, not the shipped package's xz (scripts/package.sh): what this test reads is the same, and xz was
    # 45 of cpack's 50 s of CPU: beside two CPU hogs and the other tests it ran out the 280 s.
    res = run("cpack", "-G", "DEB", "-B", out, "--config", os.path.join(build, "CPackConfig.cmake"),
              "-D", "CPACK_DEBIAN_COMPRESSION_TYPE=gzip", timeout=280)
    assert res.returncode == 0, res.stdout + res.stderr
    debs = [f for f in os.listdir(out) if f.endswith(".deb")]
    assert len(debs) == 1, debs
    return os.path.join(out, debs[0])


def check_control(deb, version):
    fields = {}
    for line in run("dpkg-deb", "-f", deb).stdout.splitlines():
        if ": " in line and not line.startswith(" "):
            k, v = line.split(": ", 1)
            fields[k] = v
    assert fields["Package"] == "guideway", fields
    assert fields["Version"] == version, (fields["Version"], version)
    assert fields["Section"] == "science" and fields["Priority"] == "optional", fields
    depends = [d.strip().split(" ")[0] for d in fields["Depends"].split(",")]
    for d in ("python3", "systemd", "libc6", "libstdc++6", "libmodbus5", "libserialport0", "libsystemd0"):
        assert d in depends, (d, fields["Depends"])
    assert fields.get("Suggests") == "linuxcnc-uspace", fields
    print(f"control: {fields['Package']} {fields['Version']} {fields['Architecture']}, depends on {len(depends)} "
          f"packages, suggests {fields['Suggests']}")


def check_files(deb, root):
    names = [line.split()[-1].lstrip("./") for line in run("dpkg-deb", "-c", deb).stdout.splitlines()]
    missing = [f for f in EXPECTED if f not in names]
    assert not missing, missing
    stray = [n for n in names if n.startswith("usr/local") or "/tests/" in n or "test" in os.path.basename(n)]
    assert not stray, stray
    subprocess.run(["dpkg-deb", "-x", deb, root], check=True)
    for f in EXECUTABLE:
        assert os.stat(os.path.join(root, f)).st_mode & stat.S_IXUSR, f
    with open(os.path.join(root, "usr/lib/tmpfiles.d/guideway.conf")) as f:
        assert re.search(r"^d /run/guideway-linuxcnc 0775 root guideway -$", f.read(), re.M)
    print(f"files: {len(names)} entries, the {len(EXPECTED)} expected ones among them, nothing under /usr/local")


def check_scripts(deb, work):
    """The maintainer scripts, run with stand-ins for systemd's tools that record their arguments."""
    control = os.path.join(work, "control")
    subprocess.run(["dpkg-deb", "-e", deb, control], check=True)
    with open(os.path.join(control, "conffiles")) as f:
        assert f.read().split() == ["/etc/guideway/guideway.toml"]
    stubs = os.path.join(work, "stubs")
    os.makedirs(stubs)
    log = os.path.join(work, "calls.log")
    for tool in ("systemd-sysusers", "systemd-tmpfiles", "systemctl", "deb-systemd-invoke"):
        with open(os.path.join(stubs, tool), "w") as f:
            f.write(f"#!/bin/sh\necho \"{tool} $*\" >> {log}\n")
        os.chmod(os.path.join(stubs, tool), 0o755)
    env = {"PATH": f"{stubs}:/usr/bin:/bin"}

    def calls(script, *args):
        if os.path.exists(log):
            os.remove(log)
        res = run("sh", "-e", os.path.join(control, script), *args, env=env)
        assert res.returncode == 0, (script, args, res.stderr)
        return open(log).read().splitlines() if os.path.exists(log) else []

    for script in ("postinst", "prerm", "postrm"):
        assert run("sh", "-n", os.path.join(control, script)).returncode == 0, script
        with open(os.path.join(control, script)) as f:
            code = "\n".join(l for l in f.read().splitlines() if not l.lstrip().startswith("#"))
        assert "rm " not in code and "/var/lib/guideway" not in code, (script, code)  # measured data stays
    got = calls("postinst", "configure", "")
    assert got[:2] == ["systemd-sysusers guideway.conf", "systemd-tmpfiles --create guideway.conf"], got
    assert not any("enable" in c or " start" in c for c in got), got
    assert calls("postinst", "abort-upgrade", "0.1.0") == [], "postinst acts on configure only"
    removed = calls("prerm", "remove")
    upgraded = calls("prerm", "upgrade", "0.2.0")
    systemd_running = os.path.isdir("/run/systemd/system")
    if systemd_running:
        assert removed == ["deb-systemd-invoke stop guidewayd.service guideway-fleet.service"], removed
    assert upgraded == [], upgraded
    print(f"maintainer scripts: postinst {got}; prerm on remove {removed or '(no systemd here)'}, on upgrade "
          "nothing; postrm keeps /var/lib/guideway")


def check_programs(root):
    guideway = os.path.join(root, "usr/bin/guideway")
    res = run(guideway, "--version")
    assert res.returncode == 0 and re.search(r"\d+\.\d+\.\d+", res.stdout), res.stdout + res.stderr
    res = run(os.path.join(root, "usr/sbin/guidewayd"), "--config", os.path.join(root, "etc/guideway/guideway.toml"),
              "--check-config", timeout=60)
    assert res.returncode == 0, res.stdout + res.stderr
    res = run(sys.executable, os.path.join(root, "usr/share/guideway/linuxcnc/linuxcnc_loop.py"), "--help")
    assert res.returncode == 0 and "--share-dir" in res.stdout, res.stdout + res.stderr
    print("programs: guideway --version, guidewayd --check-config of the packaged configuration, the loop's --help")


def check_lintian(deb):
    if not shutil.which("lintian"):
        print("lintian: not installed (scripts/setup.sh installs it): not checked")
        return
    res = run("lintian", "--fail-on", "error,warning", "--tag-display-limit", "0", deb, timeout=240)
    tags = [l for l in res.stdout.splitlines() if re.match(r"^[EW]: ", l)]
    assert res.returncode == 0 and not tags, res.stdout + res.stderr
    print("lintian: no error, no warning")


def main():
    build, source = sys.argv[1], sys.argv[2]
    if not shutil.which("cpack") or not shutil.which("dpkg-deb"):
        print("SKIP: cpack or dpkg-deb missing")
        return SKIP
    with open(os.path.join(source, "CMakeLists.txt")) as f:
        version = re.search(r"project\(guideway VERSION ([0-9.]+)", f.read()).group(1)
    with tempfile.TemporaryDirectory(prefix="guideway-package-") as work:
        deb = build_package(build, os.path.join(work, "out"))
        print(f"built {os.path.basename(deb)} ({os.path.getsize(deb) // 1024} KiB)")
        check_control(deb, version)
        root = os.path.join(work, "root")
        check_files(deb, root)
        check_scripts(deb, work)
        check_programs(root)
        check_lintian(deb)
    return 0


if __name__ == "__main__":
    sys.exit(main())
