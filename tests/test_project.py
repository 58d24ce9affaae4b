"""Project wiring: CI runs exactly README's test command."""

import os
import re

ROOT = os.path.join(os.path.dirname(__file__), os.pardir)


def read(path):
    with open(os.path.join(ROOT, path)) as f:
        return f.read()


def readme_commands():
    return re.findall(r"```bash\n(.*?)\n```", read("README.md"), flags=re.S)


def test_ci_runs_readme_test_command():
    commands = readme_commands()
    test_commands = [c for c in commands if "pytest" in c]
    assert len(test_commands) == 1
    ci_lines = [line for line in read(".ci/run").splitlines() if line and not line.startswith("#")]
    assert ci_lines[-1] == test_commands[0]


def test_readme_main_job_renders_the_default_scene():
    main = [c for c in readme_commands() if "render" in c]
    assert main and "scenes/default.xml" in main[0]
    assert os.path.exists(os.path.join(ROOT, "scenes", "default.xml"))
