#!/usr/bin/env python3
"""Runs every command of the README's ```sh blocks, as written, from a copy of the repository.

The README promises that its examples run; this is the check. Blocks fenced as ```sh are run in
order (a line ending in a backslash continues on the next); plain ``` blocks (the install and
test commands, which are CI itself) are not. The copy holds the folders the commands read
(models, share, data, plugins' setups...) and a link to the build folder, so the commands' outputs
never land in the checkout. Exits 1 naming the first command that fails.

usage: check-readme.py REPO BUILD_DIR [WORK_DIR]
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile


def commands(readme_text):
    """The ```sh blocks' commands in order, continuation lines joined."""
    out = []
    for block in re.findall(r"^```sh\n(.*?)^```", readme_text, flags=re.S | re.M):
        pending = ""
        for line in block.splitlines():
            if line.rstrip().endswith("\\"):
                pending += line.rstrip()[:-1] + " "
                continue
            cmd = (pending + line).strip()
            pending = ""
            if cmd and not cmd.startswith("#"):
                out.append(cmd)
    return out


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    repo, build = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    work = os.path.abspath(sys.argv[3]) if len(sys.argv) > 3 else tempfile.mkdtemp(prefix="kneesim_readme_")
    readme = os.path.join(repo, "README.md")
    cmds = commands(open(readme, encoding="utf-8").read())
    if not cmds:
        sys.exit(f"{readme}: no ```sh block found")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    for entry in os.listdir(repo):
        if entry in (".git",) or entry.startswith("build"):
            continue
        src = os.path.join(repo, entry)
        dst = os.path.join(work, entry)
        if os.path.isdir(src):
            shutil.copytree(src, dst, symlinks=True)
        else:
            shutil.copy2(src, dst, follow_symlinks=False)
    os.symlink(build, os.path.join(work, "build"))
    print(f"README commands: {len(cmds)}, run in {work}")
    for i, cmd in enumerate(cmds, 1):
        print(f"[{i}/{len(cmds)}] $ {cmd}", flush=True)
        r = subprocess.run(["bash", "-eo", "pipefail", "-c", cmd], cwd=work)
        if r.returncode != 0:
            print(f"{readme}: command {i} failed with exit status {r.returncode}: {cmd}")
            return 1
    shutil.rmtree(work, ignore_errors=True)
    print("every README command ran")
    return 0


if __name__ == "__main__":
    sys.exit(main())
