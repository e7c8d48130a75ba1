#!/usr/bin/python3
"""The candp2 Python package as a user gets it (docs/python.md "Install"):

  --mode pip   `pip install ./python` offline (no index: Debian's setuptools, nothing to
               download) into a virtual environment that sees Debian's python3-can and
               python3-pymodbus (--system-site-packages);
  --mode deb   the two packages of `tools/setup.sh deb` (dist/candp2_*.deb,
               dist/python3-candp2_*_all.deb): `apt-get install --simulate` resolves their
               Depends on this machine, then both are unpacked (dpkg-deb -x) into a temporary
               root, which stands in for / (PATH and PYTHONPATH point into it). Skipped (77)
               when dist/ has no packages.

Either way:
  1. `import candp2` comes from the installation, and it registers the entry points pytest11
     candp2.pytest_plugin and can.interface candp2 (`can.Bus(interface="candp2", ...)`);
  2. a throwaway project outside the repository (one 10-line test file, no conftest, no -p
     option) passes: pytest finds the plugin through its entry point and candp2d on PATH;
  3. deb mode: the examples as shipped (/usr/share/doc/python3-candp2/examples, the same files
     as python/examples) pass against the installed /usr/bin/candp2d, also with pytest-xdist
     (-n 4);
  4. the README's Python example passes from an empty folder: deb mode against the installed
     candp2d; pip mode against the build tree's (`pytest --candp2d BUILD/bin/candp2d`, no
     candp2d on PATH), whose examples candp2.example() finds through the build tree's source.

pip mode installs from the checkout's python/ itself, as docs/python.md says, and fails when
that leaves anything behind there (build/, candp2.egg-info).

The deb mode unpacks instead of installing so that it needs no root, changes nothing on the
machine and can run beside other tests; installing with apt on a fresh Debian 12 is shown in
docs/python.md.

  python_test.py --mode pip --candp2d build/bin/candp2d
  python_test.py --mode deb --dist dist --version 0.1.0
"""

import argparse
import filecmp
import glob
import os
import re
import shutil
import subprocess
import sys
import tempfile

SKIP = 77
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# python-can's own factory finds the package's bus through the can.interface entry point.
CAN_BUS = '''\
import can, candp2
config = {"buses": {"can0": {"type": "virtual"}},
          "gateways": [{"address": 3, "bus": "can0", "slots": [
              {"io": "output", "address": 0, "length": 2, "comment": "02,01,00"},
              {"io": "input", "address": 0, "length": 2, "comment": "01,81,00"}]}]}
with candp2.Daemon(config) as daemon:
    host, port = daemon.socketcand["can0"]
    with can.Bus(interface="candp2", channel="can0", host=host, port=port) as bus:
        gw = daemon.gateway(3)
        gw.wait_until(lambda g: g.state == "Data_Exch")
        bus.send(can.Message(arbitration_id=0x181, data=b"\\x12\\x34", is_extended_id=False))
        gw.wait_until(lambda g: g.inputs[0:2] == b"\\x12\\x34")
print("can.Bus(interface='candp2') ok")
'''

THROWAWAY = '''\
def test_gateway_sends_what_the_plc_writes(candp2d):
    daemon = candp2d({
        "buses": {"can0": {"type": "virtual"}},
        "gateways": [{"address": 3, "bus": "can0", "slots": [
            {"io": "output", "address": 0, "length": 2, "comment": "03,09,00"}]}]})
    gw, can0 = daemon.gateway(3), daemon.bus("can0")
    gw.wait_until(lambda g: g.state == "Data_Exch")
    gw.outputs[0:2] = b"\\x12\\x34"
    can0.expect(0x309, b"\\x12\\x34")
'''


def fail(msg):
    raise SystemExit("FAIL: " + msg)


def run(argv, **kw):
    print("$", " ".join(argv), flush=True)
    r = subprocess.run(argv, capture_output=True, text=True, timeout=300, **kw)
    return r


def check_installation(python, env, where):
    """1: the module and the entry point come from `where`."""
    r = run([python, "-c", "import candp2, importlib.metadata as m; print(candp2.__file__); "
             "print([e.value for e in m.entry_points(group='pytest11') "
             "if e.name == 'candp2.pytest_plugin']); "
             "import can.interfaces as i; print(i.BACKENDS.get('candp2'))"], env=env)
    if r.returncode != 0:
        fail("import candp2: %s" % r.stderr)
    module, entry, backend = r.stdout.splitlines()[:3]
    if not os.path.realpath(module).startswith(os.path.realpath(where)):
        fail("candp2 imported from %s, not from the installation in %s" % (module, where))
    if entry != "['candp2.pytest_plugin']":
        fail("pytest11 entry point candp2.pytest_plugin not registered: %s" % entry)
    if backend != "('candp2.bus', 'Bus')":
        fail("python-can interface candp2 not registered: %s" % backend)
    print("ok: candp2 from %s, entry points pytest11 candp2.pytest_plugin and can.interface "
          "candp2" % module)


def run_pytest(python, env, cwd, *args):
    r = run([python, "-m", "pytest", "-p", "no:cacheprovider", *args], env=env, cwd=cwd)
    print(r.stdout[-3000:])
    if r.returncode != 0:
        fail("pytest %s in %s: exit %d\n%s" % (" ".join(args), cwd, r.returncode, r.stderr))
    if "plugins:" not in r.stdout or "candp2" not in r.stdout.split("plugins:", 1)[1].split(
            "\n", 1)[0]:
        fail("pytest does not list the candp2 plugin")
    return r.stdout


def throwaway_project(python, env, tmp):
    """2: one test file, no conftest, no options: the entry point and PATH do it all."""
    project = os.path.join(tmp, "throwaway")
    os.makedirs(project)
    with open(os.path.join(project, "test_plant.py"), "w") as f:
        f.write(THROWAWAY)
    if len(THROWAWAY.splitlines()) > 10:
        fail("the throwaway test has more than 10 lines")
    out = run_pytest(python, env, project, "-v")
    if "test_gateway_sends_what_the_plc_writes PASSED" not in out:
        fail("the throwaway project's test did not pass")
    print("ok: throwaway project (no conftest) passes through the entry point")


def mode_pip(args, tmp):
    venv = os.path.join(tmp, "venv")
    r = run(["/usr/bin/python3", "-m", "venv", "--system-site-packages", venv])
    if r.returncode != 0:
        fail("venv: %s" % r.stderr)
    # From the checkout, as docs/python.md says: setup.py builds in a scratch folder, so the
    # checkout must look the same afterwards (__pycache__ aside, which tests write anyway).
    source = os.path.join(ROOT, "python")

    def entries():
        return {e for e in os.listdir(source) if e != "__pycache__"}

    before = entries()
    python = os.path.join(venv, "bin", "python")
    r = run([python, "-m", "pip", "install", "--no-index", source], cwd=ROOT)
    if r.returncode != 0:
        fail("pip install --no-index ./python:\n%s%s" % (r.stdout, r.stderr))
    if entries() != before:
        fail("pip install ./python wrote %s into the checkout" % sorted(entries() - before))
    print("ok: pip install --no-index ./python, nothing written into the checkout")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    bare = dict(env)  # no candp2d on PATH: the README example gets it with --candp2d
    env["PATH"] = os.path.dirname(os.path.abspath(args.candp2d)) + os.pathsep + env["PATH"]
    check_installation(python, env, venv)
    r = run([python, "-c", CAN_BUS], env=env, cwd=tmp)
    if r.returncode != 0 or "ok" not in r.stdout:
        fail("can.Bus(interface='candp2'): %s%s" % (r.stdout, r.stderr))
    print("ok: " + r.stdout.strip())
    throwaway_project(python, env, tmp)
    # (--candp2d wins over a candp2d on PATH, so an installed one changes nothing here)
    readme_example(python, bare, tmp, "--candp2d", os.path.abspath(args.candp2d))


def mode_deb(args, tmp):
    arch = run(["dpkg", "--print-architecture"]).stdout.strip()
    debs = [os.path.join(args.dist, "candp2_%s-1_%s.deb" % (args.version, arch)),
            os.path.join(args.dist, "python3-candp2_%s-1_all.deb" % args.version)]
    missing = [d for d in debs if not os.path.exists(d)]
    if missing:
        print("SKIP: %s not built (tools/setup.sh deb builds them)" % missing)
        return SKIP
    depends = run(["dpkg-deb", "-f", debs[1], "Depends"]).stdout
    for want in ("candp2 (= %s-1)" % args.version, "python3-can", "python3-pymodbus",
                 "python3-serial-asyncio"):
        if want not in depends:
            fail("python3-candp2 Depends: %s lacks %s" % (depends.strip(), want))
    print("ok: python3-candp2 Depends: " + depends.strip())
    r = run(["apt-get", "install", "--simulate", "--no-install-recommends",
             *[os.path.abspath(d) for d in debs]])
    if r.returncode != 0:
        fail("apt-get install --simulate: the packages cannot be installed here:\n%s%s"
             % (r.stdout, r.stderr))
    print("ok: apt-get install --simulate resolves both packages")
    root = os.path.join(tmp, "root")
    for d in debs:
        if run(["dpkg-deb", "-x", d, root]).returncode != 0:
            fail("dpkg-deb -x " + d)
    site = os.path.join(root, "usr", "lib", "python3", "dist-packages")
    env = dict(os.environ, PYTHONPATH=site,
               PATH=os.path.join(root, "usr", "bin") + os.pathsep + os.environ["PATH"])
    python = "/usr/bin/python3"
    check_installation(python, env, site)
    throwaway_project(python, env, tmp)
    shipped = os.path.join(root, "usr", "share", "doc", "python3-candp2", "examples")
    ours = sorted(os.path.basename(p) for p in glob.glob(os.path.join(ROOT, "python",
                                                                      "examples", "*.py")))
    match, mismatch, errors = filecmp.cmpfiles(shipped, os.path.join(ROOT, "python", "examples"),
                                               ours, shallow=False)
    if mismatch or errors or not match:
        fail("shipped examples differ from python/examples: %s %s" % (mismatch, errors))
    examples = os.path.join(tmp, "examples")
    shutil.copytree(shipped, examples)
    out = run_pytest(python, env, examples, "-v")
    print("ok: the shipped examples pass against %s/usr/bin/candp2d" % root)
    out = run_pytest(python, env, examples, "-v", "-n", "4")
    if "passed" not in out:
        fail("pytest -n 4 python/examples")
    print("ok: pytest -n 4 on the examples")
    # As a user runs them (no -p no:cacheprovider): the shipped pytest.ini keeps pytest from
    # writing a .pytest_cache beside them (under /usr/share/doc when run in place as root).
    r = run([python, "-m", "pytest", "-q", "-k", "enable_axis1"], env=env, cwd=examples)
    if r.returncode != 0 or os.path.exists(os.path.join(examples, ".pytest_cache")):
        fail("pytest in the shipped examples: exit %d, .pytest_cache %s\n%s%s"
             % (r.returncode, "written" if os.path.exists(os.path.join(examples, ".pytest_cache"))
                else "not written", r.stdout[-2000:], r.stderr[-2000:]))
    print("ok: the shipped examples leave no .pytest_cache")
    readme_example(python, env, tmp)
    return 0


def readme_example(python, env, tmp, *args):
    """The README's Python example, as it stands there, from an empty folder: it finds the
    shipped demo configuration with candp2.example(). `args` go to pytest (--candp2d)."""
    with open(os.path.join(ROOT, "README.md")) as f:
        block = re.search(r"```python\n(.*?)```", f.read(), re.S)
    if block is None:
        fail("README.md has no python example")
    folder = os.path.join(tmp, "empty")
    os.makedirs(folder)
    with open(os.path.join(folder, "test_readme.py"), "w") as f:
        f.write(block.group(1))
    out = run_pytest(python, env, folder, "-v", *args)
    if " PASSED" not in out or "failed" in out:
        fail("the README's example from an empty folder:\n" + out)
    print("ok: the README's example passes from an empty folder %s" % " ".join(args))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mode", choices=("pip", "deb"), required=True)
    ap.add_argument("--candp2d", help="pip mode: the candp2d put on PATH")
    ap.add_argument("--dist", default=os.path.join(ROOT, "dist"))
    ap.add_argument("--version")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="candp2-python-") as tmp:
        if args.mode == "pip":
            if not args.candp2d:
                fail("--mode pip needs --candp2d")
            mode_pip(args, tmp)
            rc = 0
        else:
            if not args.version:
                fail("--mode deb needs --version")
            rc = mode_deb(args, tmp)
    if rc == 0:
        print("python %s test passed" % args.mode)
    return rc


if __name__ == "__main__":
    sys.exit(main())
