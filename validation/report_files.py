"""How the plot scripts write what they make: under a part name, synced to disk, then renamed,
so that a failed or interrupted run never leaves a half-written picture or table under its
final name (the same rule as the C++ writers, common/internal/irdm_common/files.h)."""
import os
import sys


def _sync_and_rename(part, path):
    with open(part, "rb") as fh:
        os.fsync(fh.fileno())
    os.replace(part, path)
    folder = os.open(os.path.dirname(os.path.abspath(path)), os.O_RDONLY)
    try:
        os.fsync(folder)
    finally:
        os.close(folder)


def save_figure(fig, path, **savefig_options):
    """fig.savefig(path, ...) through "<path>.part.<ext>"; the figure is closed afterwards."""
    import matplotlib.pyplot as plt
    path = str(path)
    root, ext = os.path.splitext(path)
    part = path + ".part" + (ext or ".png")
    try:
        fig.savefig(part, **savefig_options)
        _sync_and_rename(part, path)
    except BaseException:
        if os.path.exists(part):
            os.remove(part)
        raise
    finally:
        plt.close(fig)


def write_text(path, text):
    """A text file (Markdown, CSV) through "<path>.part"."""
    path = str(path)
    part = path + ".part"
    try:
        with open(part, "w") as fh:
            fh.write(text)
        _sync_and_rename(part, path)
    except BaseException:
        if os.path.exists(part):
            os.remove(part)
        raise


ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def git(*args):
    """git's output in the source tree (paths relative to its top), or None if git fails."""
    import subprocess
    try:
        return subprocess.run(["git", "-C", ROOT, *args], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None


def stamp():
    """The line every report states about itself, as irdm_common/report_stamp.h writes it:
    "Made on <date> UTC at commit <sha>[+changes] (<what>)."."""
    import time
    commit = git("rev-parse", "--short=7", "HEAD")
    if commit is None:
        where = "an unknown commit"
    else:
        # Changes to the committed reports themselves (which a run rewrites) do not count.
        changes = git("status", "--porcelain", "--untracked-files=no", "--", ".",
                      ":(exclude)reports")
        where = "commit " + commit + ("+changes" if changes else "")
    date = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    return f"Made on {date} at {where} (validation/{os.path.basename(sys.argv[0])})."
