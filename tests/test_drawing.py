"""Drawing figures in other processes (radiosim.drawing) and the paper's figures drawn there."""

import os
import pickle
import shutil
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from radiosim import drawing

pytestmark = pytest.mark.skipif(os.name != "posix" or drawing._cores() < 2,
                                reason="drawing processes need two cores and POSIX pipes")


@pytest.fixture(autouse=True)
def no_idle_drawers():
    drawing.stop_drawers()
    yield
    drawing.stop_drawers()


@pytest.fixture
def matplotlib_as_read():
    """matplotlib's settings as read from its files, whatever earlier tests set (restored)."""
    import matplotlib

    with matplotlib.rc_context():
        matplotlib.rc_file_defaults()
        yield


@pytest.fixture
def replies(monkeypatch):
    """The replies the drawing processes sent (``None`` where the job then ran here)."""
    seen = []
    receive = drawing._receive

    def recorded(process):
        seen.append(receive(process))
        return seen[-1]

    monkeypatch.setattr(drawing, "_receive", recorded)
    return seen


def test_a_job_runs_in_a_drawing_process_and_its_value_comes_back():
    assert drawing.start_drawers(2) == 2
    assert drawing.start_drawers(2) == 2  # the idle ones are reused, none started
    pids = drawing.draw_aside([(os.getpid, ()), (os.getpid, ()), (abs, (-3,))])
    assert os.getpid() not in pids[:2] and pids[0] != pids[1]  # one process per job
    assert pids[2] == 3  # no process left for it: run here
    assert drawing.idle_drawers() == 0


def test_without_drawing_processes_the_jobs_run_here_in_order():
    assert drawing.draw_aside([(os.getpid, ()), (divmod, (7, 2))]) == [os.getpid(), (3, 1)]


def test_a_job_that_does_not_pickle_runs_here_and_leaves_the_process_idle():
    drawing.start_drawers(1)
    assert drawing.draw_aside([(lambda: os.getpid(), ())]) == [os.getpid()]
    assert drawing.idle_drawers() == 1


def test_a_drawing_process_that_ended_leaves_its_job_to_this_one():
    drawing.start_drawers(1)
    process = drawing._IDLE[0]
    process.kill()
    process.wait()
    assert drawing.draw_aside([(os.getpid, ())]) == [os.getpid()]


def test_a_job_that_raises_there_runs_here_and_raises_here():
    drawing.start_drawers(1)
    with pytest.raises(ValueError, match="invalid literal"):
        drawing.draw_aside([(int, ("x",))])
    assert drawing.idle_drawers() == 0


def test_the_warnings_a_job_raises_there_are_raised_here(replies):
    drawing.start_drawers(1)
    with pytest.warns(UserWarning, match="drawn elsewhere"):
        assert drawing.draw_aside([(warnings.warn, ("drawn elsewhere", UserWarning))]) == [None]
    assert len(replies) == 1 and replies[0] is not None  # raised there, not run again here


def test_every_warning_raised_there_meets_this_process_filters_as_from_its_module(replies):
    """Recorded there whatever the filters there (a DeprecationWarning too, both of two
    repeats); here this process's filters decide, by category and by module."""
    job = (warnings.warn, ("old way", DeprecationWarning))
    drawing.start_drawers(2)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        drawing.draw_aside([job, job])
    assert [(w.category, str(w.message)) for w in seen] == [(DeprecationWarning, "old way")] * 2
    drawing.start_drawers(1)
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", module=r"radiosim\.drawing")  # where warn ran there
        drawing.draw_aside([job])
    assert seen == []
    assert len(replies) == 3 and None not in replies  # all three were raised there


def test_matplotlib_counts_as_set_up_here_only_once_its_settings_changed(matplotlib_as_read):
    import matplotlib

    assert not drawing.matplotlib_configured()  # imported, as read from its files
    with matplotlib.rc_context({"lines.linewidth": 3.5}):
        assert drawing.matplotlib_configured()
    assert not drawing.matplotlib_configured()


def test_a_job_runs_in_this_process_working_folder(tmp_path, monkeypatch, replies):
    drawing.start_drawers(1)
    monkeypatch.chdir(tmp_path)
    assert drawing.draw_aside([(os.getcwd, ())]) == [str(tmp_path)]
    assert replies[0] is not None


def test_a_forked_child_holding_copies_of_the_pipes_does_not_hold_a_job():
    drawing.start_drawers(1)
    child = os.fork()
    if child == 0:  # a multiprocessing or Dask worker forked now would hold the pipes
        time.sleep(5)
        os._exit(0)
    try:
        began = time.perf_counter()
        pid = drawing.draw_aside([(os.getpid, ())])[0]
        assert pid not in (os.getpid(), child) and time.perf_counter() - began < 4
    finally:
        os.kill(child, signal.SIGKILL)
        os.waitpid(child, 0)


def _handles_sigterm(pid) -> bool:
    """Whether process ``pid`` has a handler for SIGTERM (Linux: its status's SigCgt mask)."""
    with open(f"/proc/{pid}/status") as status:
        caught = next(int(line.split()[1], 16) for line in status if line.startswith("SigCgt"))
    return bool(caught >> (signal.SIGTERM - 1) & 1)


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads /proc (Linux)")
def test_a_drawing_process_unwinds_when_stopped_at_any_moment():
    """SIGTERM while it starts, imports or runs its job: it ends within the grace; once its
    handler is in, unwinding as on Ctrl-C (its ``finally`` blocks remove their partial files;
    before that it has written nothing) and ending with 130, not killed by the signal."""
    for wait in (None, 0.0, 4.0):  # starting; importing matplotlib; in its job
        drawing.start_drawers(1)
        process = drawing._IDLE.pop()
        assert drawing._send(process, pickle.dumps((os.getcwd(), time.sleep, (60,))))
        if wait is not None:
            for _ in range(200):
                if _handles_sigterm(process.pid):
                    break
                time.sleep(0.05)
            time.sleep(wait)
        began = time.perf_counter()
        drawing._stop(process, grace=10)
        assert time.perf_counter() - began < 5
        assert process.returncode in ((130, -signal.SIGTERM) if wait is None else (130,))


def test_an_idle_drawing_process_ends_with_its_parent():
    code = ("import sys, time; from radiosim import drawing; drawing.start_drawers(1); "
            "print(drawing._IDLE[0].pid, flush=True); time.sleep(60)")
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    with parent.stdout:
        child = int(parent.stdout.readline())
    parent.kill()
    parent.wait()
    for _ in range(100):  # its stdin closed, or its parent gone: it ends within a second
        try:
            os.kill(child, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    else:
        os.kill(child, signal.SIGKILL)
        pytest.fail("the drawing process outlived its parent")


@pytest.fixture(scope="module")
def small_results(tmp_path_factory):
    """The results folder of the CLI tests' small study (its figures not drawn) and its
    scene."""
    from radiosim.study import Study
    from test_cli import SMALL_STUDY

    folder = tmp_path_factory.mktemp("small")
    (folder / "small.toml").write_text(SMALL_STUDY)
    study = Study.from_toml(folder / "small.toml")
    study.run(folder / "out", write_exr=True)
    return folder / "out", study.scene


def test_the_paper_figures_drawn_in_processes_are_the_files_drawn_here(
        tmp_path, monkeypatch, replies, small_results, matplotlib_as_read):
    from radiosim.paper import figures as F

    results, scene = small_results
    shutil.copytree(results, tmp_path / "out")
    # As radiosim run: drawing processes, and matplotlib not set up here.
    assert drawing.start_drawers(drawing.DRAWERS) == drawing.DRAWERS
    (tmp_path / "out" / "figures").mkdir()
    left = tmp_path / "out" / "figures" / ".fig05_peak.png.k1lled.partial"
    left.write_bytes(b"a drawing process killed mid-write")
    monkeypatch.chdir(tmp_path)
    written = F.make_figures("out", scene)  # a folder relative to this one
    assert drawing.idle_drawers() == 0 and len(replies) == 2 and None not in replies
    assert not left.exists()
    names = [p.name for p in written]
    assert names == ["fig05_peak.png", "fig07_column_I.png", "fig06_profiles.png",
                     "fig09-11_maps.png"]  # the written order, whoever drew them
    assert written[0] == Path("out") / "figures" / "fig05_peak.png"  # as the caller named it
    here = tmp_path / "here"
    shutil.copytree(results, here)
    (here / "figures").mkdir()
    F.draw_figures(here, names, scene)
    for name in names:
        assert (here / "figures" / name).read_bytes() == (tmp_path / "out" / "figures" /
                                                          name).read_bytes(), name


def test_figures_are_drawn_here_when_matplotlib_was_set_up_here(tmp_path, small_results):
    """A caller's rcParams hold for the figures: with them changed, no drawing process draws,
    and the figures show them."""
    import matplotlib

    from radiosim.paper import figures as F

    results, scene = small_results
    shutil.copytree(results, tmp_path / "set")
    shutil.copytree(results, tmp_path / "plain")
    drawing.start_drawers(1)
    with matplotlib.rc_context({"lines.linewidth": 4.0}):
        F.make_figures(tmp_path / "set", scene)
    assert drawing.idle_drawers() == 1  # not sent to it
    (tmp_path / "plain" / "figures").mkdir()
    F.draw_figures(tmp_path / "plain", ["fig05_peak.png"], scene)
    assert ((tmp_path / "set" / "figures" / "fig05_peak.png").read_bytes()
            != (tmp_path / "plain" / "figures" / "fig05_peak.png").read_bytes())


def test_a_run_without_figures_starts_no_drawing_process_nor_prepares(tmp_path, monkeypatch):
    from radiosim.cli import main
    from radiosim.paper import figures as F
    from test_cli import SMALL_STUDY

    started, prepared = [], []
    monkeypatch.setattr(drawing, "start_drawers", lambda *a, **k: started.append(a) or 0)
    monkeypatch.setattr(F.make_figures, "prepare", lambda: prepared.append(1))
    study = tmp_path / "small.toml"
    study.write_text(SMALL_STUDY.replace("radiosim.paper:make_figures",
                                         "radiosim.paper.figures:make_figures"))
    assert main(["run", str(study), "--out", str(tmp_path / "o"), "--no-figures", "-q"]) == 0
    assert started == [] and prepared == [] and not (tmp_path / "o" / "figures").exists()
    assert main(["run", str(study), "--out", str(tmp_path / "p"), "-q"]) == 0
    assert started == [(drawing.DRAWERS,)] and prepared == [1]  # the same, with figures
