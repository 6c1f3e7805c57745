"""``robot check --format junit``: one test case per link, failures the statuses that fail the run, written by
the project's one JUnit writer (the same that ``regress --junit`` uses)."""

import textwrap
from xml.etree import ElementTree

from click.testing import CliRunner

from massprops.cli import main
from massprops.report.junit import junit


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _robot(tmp_path):
    box = '<collision><geometry><box size="1 2 3"/></geometry></collision>'
    path = tmp_path / "r.urdf"
    path.write_text(textwrap.dedent(f"""\
        <robot name="r">
          <link name="good"><inertial><mass value="6"/>
            <inertia ixx="6.5" ixy="0" ixz="0" iyy="5" iyz="0" izz="2.5"/></inertial>{box}</link>
          <link name="off"><inertial><mass value="6"/>
            <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>{box}</link>
          <link name="bad"><inertial><mass value="6"/>
            <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="3"/></inertial>{box}</link>
          <link name="frame"/>
        </robot>
        """), encoding="utf-8")
    return path


def _cases(xml):
    root = ElementTree.fromstring(xml.encode("utf-8") if isinstance(xml, str) else xml)
    (suite,) = root.findall("testsuite")
    return suite, {case.get("name"): case for case in suite.findall("testcase")}


def test_one_case_per_link_and_failures_by_status(tmp_path):
    path = _robot(tmp_path)
    result = run("robot", "check", path, "--format", "junit")
    assert result.exit_code == 1                                    # 'bad' is invalid
    suite, cases = _cases(result.stdout)
    assert list(cases) == ["good", "off", "bad", "frame"]
    assert suite.get("tests") == "4" and suite.get("failures") == "1" and suite.get("errors") == "0"
    assert cases["bad"].find("failure").get("type") == "invalid"
    assert cases["off"].find("failure") is None and cases["good"].find("failure") is None
    strict = run("robot", "check", path, "--format", "junit", "--strict")
    suite, cases = _cases(strict.stdout)
    assert suite.get("failures") == "2" and cases["off"].find("failure").get("type") == "mismatch"
    # --junit FILE beside the text is the same document.
    target = tmp_path / "out.xml"
    run("robot", "check", path, "--junit", target)
    assert [c.get("name") for c in _cases(target.read_text())[0]] == list(cases)


def test_a_model_that_cannot_be_read_is_one_error(tmp_path):
    path = tmp_path / "broken.urdf"
    path.write_text("<robot name='x'><link name='a'>", encoding="utf-8")
    result = run("robot", "check", path, "--format", "junit")
    suite, cases = _cases(result.stdout)
    assert result.exit_code == 1 and suite.get("errors") == "1" and list(cases) == [str(path)]


def test_the_writer_counts_and_escapes():
    xml = junit([{"name": "s", "properties": {"k": "v"}, "cases": [
        {"name": "a\x1bb", "classname": "c", "time": 0.5},
        {"name": "f", "classname": "c", "time": 0.25, "failure": {"message": "m<&>", "text": "line 1\nline 2"}},
        {"name": "e", "classname": "c", "error": {"message": "boom"}}]}], name="all")
    root = ElementTree.fromstring(xml.split("\n", 1)[1])
    suite = root.find("testsuite")
    assert root.get("name") == "all"
    assert (suite.get("tests"), suite.get("failures"), suite.get("errors"), suite.get("time")) == ("3", "1", "1",
                                                                                                   "0.750")
    names = [c.get("name") for c in suite.findall("testcase")]
    assert names == ["a\\x1bb", "f", "e"]
    failure = suite.findall("testcase")[1].find("failure")
    assert failure.get("message") == "m<&>" and failure.text == "line 1\nline 2"
    assert suite.find("properties/property").get("value") == "v"
