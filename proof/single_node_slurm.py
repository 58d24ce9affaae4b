"""A single-node Slurm on this machine, for the tests and the benchmark of
``pbrdf batch --slurm`` (docs/batch.md): ``munged``, ``slurmctld`` and
``slurmd`` from Debian's packages (``.ci/install-slurm.sh``), started as root
with a configuration of their own in :data:`STATE` (this host is the only
node, partition ``debug``), and stopped again.

Everything lives in :data:`STATE` (configuration, sockets, pid files, logs,
spool): the daemons a previous run left running are found there by their pid
files and stopped before a new start, and nothing of a system-wide Slurm or
munge (ports, sockets, ``/etc/slurm``) is touched. Clients reach this Slurm
through ``SLURM_CONF`` (:meth:`SingleNodeSlurm.env`).

One run at a time: :meth:`SingleNodeSlurm.start` first takes an exclusive
lock on ``STATE + ".lock"`` (``flock``; the kernel drops it when the process
ends) and :meth:`SingleNodeSlurm.stop` gives it back, so a second test run on
the same machine waits for the first instead of stopping its daemons under
it (which left the first hanging), and says so in one line if it waits too
long.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import signal
import socket
import subprocess
import time
from typing import Dict, List, Optional

__all__ = ["SingleNodeSlurm", "missing", "PARTITION", "STATE"]

#: Folder of the configuration, sockets, pid files, logs and spool.
STATE = "/tmp/pbrdf-test-slurm"
PARTITION = "debug"
#: Ports off Slurm's defaults (6817, 6818), so a site's Slurm is left alone.
CTLD_PORT, SLURMD_PORT = 6917, 6918
DAEMONS = ("munged", "slurmctld", "slurmd")
COMMANDS = ("munged", "slurmctld", "slurmd", "sbatch", "squeue", "scancel", "scontrol", "sinfo")


def missing() -> Optional[str]:
    """Why this machine cannot start the Slurm of the tests (None: it can)."""
    absent = [c for c in COMMANDS if shutil.which(c) is None
              and not os.path.exists(f"/usr/sbin/{c}")]
    if absent:
        return (f"Slurm is not installed ({', '.join(absent)} missing): run .ci/install-slurm.sh "
                "as root (Debian packages slurmctld slurmd slurm-client munge)")
    if os.geteuid() != 0:
        return "the single-node Slurm of the tests starts its daemons as root; run as root"
    if not os.path.isfile("/etc/munge/munge.key"):
        return "no munge key (/etc/munge/munge.key): reinstall the munge package"
    return None


def _command(name: str) -> str:
    return shutil.which(name) or f"/usr/sbin/{name}"


def _memory_mb() -> int:
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemTotal:"):
                return int(line.split()[1]) // 1024
    return 1024  # pragma: no cover


def _ours(pid: int, daemon: str) -> bool:
    """Whether *pid* runs *daemon* (a pid file may name a pid reused since)."""
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return daemon.encode() in f.read().split(b"\0")[0]
    except OSError:
        return False


class SingleNodeSlurm:
    """Start with :meth:`start`, stop with :meth:`stop` (also the daemons of
    an earlier run that were left running)."""

    def __init__(self, state: str = STATE):
        self.state = state
        self.host = socket.gethostname().split(".")[0]  # `hostname -s`: what slurmd calls itself
        self.conf = os.path.join(state, "slurm.conf")
        self.lock_path = state + ".lock"
        self._lock = None

    def reserve(self, timeout: float = 1800.0) -> "SingleNodeSlurm":
        """Take the exclusive lock on :attr:`lock_path` (kept until
        :meth:`release`), waiting up to *timeout* seconds for another run to
        give it back; a one-line ``RuntimeError`` after that."""
        if self._lock is not None:
            return self
        handle = open(self.lock_path, "a")
        deadline = time.monotonic() + timeout
        while True:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() >= deadline:
                    handle.close()
                    raise RuntimeError(
                        f"another run has held the single-node Slurm for over {timeout:.0f} s "
                        f"(lock {self.lock_path})") from None
                time.sleep(0.5)
        self._lock = handle
        return self

    def release(self):
        """Give back the lock :meth:`reserve` took (nothing if not held)."""
        if self._lock is not None:
            fcntl.flock(self._lock, fcntl.LOCK_UN)
            self._lock.close()
            self._lock = None

    def env(self, base: Optional[Dict[str, str]] = None) -> Dict[str, str]:
        """*base* (default: this process's environment) with ``SLURM_CONF`` set."""
        return dict(os.environ if base is None else base, SLURM_CONF=self.conf)

    def _pidfile(self, daemon: str) -> str:
        return os.path.join(self.state, f"{daemon}.pid")

    def _config(self) -> str:
        s = self.state
        cpus = os.cpu_count() or 1
        return "\n".join([
            "ClusterName=pbrdftest",
            f"SlurmctldHost={self.host}",
            "SlurmUser=root", "SlurmdUser=root",
            f"SlurmctldPort={CTLD_PORT}", f"SlurmdPort={SLURMD_PORT}",
            "AuthType=auth/munge", "CredType=cred/munge",
            f"AuthInfo=socket={s}/munge.socket",
            f"StateSaveLocation={s}/ctld", f"SlurmdSpoolDir={s}/spool",
            f"SlurmctldPidFile={self._pidfile('slurmctld')}",
            f"SlurmdPidFile={self._pidfile('slurmd')}",
            f"SlurmctldLogFile={s}/slurmctld.log", f"SlurmdLogFile={s}/slurmd.log",
            "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none",
            "SelectType=select/cons_tres", "SelectTypeParameters=CR_Core",
            "SchedulerType=sched/builtin", "MpiDefault=none", "ReturnToService=2",
            "JobAcctGatherType=jobacct_gather/none",
            "AccountingStorageType=accounting_storage/none", "JobCompType=jobcomp/none",
            # a job past its walltime gets SIGTERM, then SIGKILL 2 s later
            "KillWait=2", "OverTimeLimit=0", "InactiveLimit=0", "MinJobAge=600",
            f"NodeName={self.host} CPUs={cpus} RealMemory={int(_memory_mb() * 0.9)} "
            "State=UNKNOWN",
            f"PartitionName={PARTITION} Nodes={self.host} Default=YES MaxTime=INFINITE State=UP",
            "",
        ])

    def run(self, *argv: str, check: bool = True, timeout: float = 30) -> str:
        """A Slurm client command against this Slurm; its stdout."""
        done = subprocess.run(list(argv), env=self.env(), capture_output=True, text=True,
                              timeout=timeout)
        if check and done.returncode != 0:
            raise RuntimeError(f"{' '.join(argv)}: {done.stderr.strip() or done.stdout.strip()}")
        return done.stdout

    def start(self, timeout: float = 60.0, lock_timeout: float = 1800.0) -> "SingleNodeSlurm":
        """Reserve the Slurm (:meth:`reserve`), stop what an earlier run left,
        write the configuration, start the daemons and wait until the node
        takes jobs."""
        self.reserve(lock_timeout)
        self._stop_daemons()
        shutil.rmtree(self.state, ignore_errors=True)
        for sub in ("", "ctld", "spool"):
            os.makedirs(os.path.join(self.state, sub), mode=0o755, exist_ok=True)
        os.chmod(self.state, 0o755)  # munged refuses a socket folder others may write
        with open(self.conf, "w") as f:
            f.write(self._config())
        s = self.state
        self._daemon([_command("munged"), "--force", f"--socket={s}/munge.socket",
                      f"--pid-file={self._pidfile('munged')}", f"--log-file={s}/munged.log",
                      f"--seed-file={s}/munged.seed", "--key-file=/etc/munge/munge.key"])
        self._daemon([_command("slurmctld"), "-f", self.conf, "-i"])
        self._daemon([_command("slurmd"), "-f", self.conf])
        deadline = time.monotonic() + timeout
        state = ""
        while time.monotonic() < deadline:
            state = self.run("sinfo", "-h", "-N", "-o", "%t", check=False).strip()
            if state in ("idle", "mix", "alloc"):
                return self
            time.sleep(0.3)
        raise RuntimeError(f"the single-node Slurm did not come up within {timeout:.0f} s "
                           f"(node state {state!r}; logs in {self.state})")

    def _daemon(self, argv: List[str]):
        done = subprocess.run(argv, env=self.env(), capture_output=True, text=True, timeout=30,
                              start_new_session=True)
        if done.returncode != 0:
            raise RuntimeError(f"{os.path.basename(argv[0])} did not start: "
                               f"{(done.stderr or done.stdout).strip()} (logs in {self.state})")

    def jobs(self) -> List[str]:
        """Ids of the jobs in the queue (any state)."""
        return self.run("squeue", "-h", "-o", "%i").split()

    def stop(self):
        """Cancel the queue's jobs, stop the daemons whose pid files are in
        :data:`STATE` (SIGTERM, SIGKILL after 10 s; no other process) and
        give back the lock."""
        try:
            self._stop_daemons()
        finally:
            self.release()

    def _stop_daemons(self):
        if os.path.exists(self._pidfile("slurmctld")):
            try:
                ids = self.jobs()
                if ids:
                    self.run("scancel", *ids, check=False)
            except (RuntimeError, OSError, subprocess.TimeoutExpired):
                pass
        for daemon in reversed(DAEMONS):
            try:
                with open(self._pidfile(daemon)) as f:
                    pid = int(f.read().split()[0])
            except (OSError, ValueError, IndexError):
                continue
            if not _ours(pid, daemon):
                continue
            os.kill(pid, signal.SIGTERM)
            deadline = time.monotonic() + 10
            while _ours(pid, daemon) and time.monotonic() < deadline:
                time.sleep(0.1)
            if _ours(pid, daemon):
                os.kill(pid, signal.SIGKILL)
