"""The class inside an LMS (LTI 1.3): an LMS run in the test process (its own RSA key, its keys published over HTTP
on loopback, its id_tokens signed with PyJWT) launches the class. A learner is signed in to the student's page, an
instructor to the teacher's desk, and never the other way round; a forged, expired, replayed or misdirected
launch is refused 401 with one line; codes keep working."""

from __future__ import annotations

import http.client
import http.server
import json
import os
import re
import stat
import time
import urllib.parse
import uuid

import jwt
import pytest
from cryptography.hazmat.primitives.asymmetric import rsa

from autonomy.liveclass import lms as lms_module
from autonomy.liveclass.lti import LtiTool, ToolKey, state_cookie
from autonomy.liveclass.server import TEACHER_TOKEN, ClassServer
from autonomy.liveclass.store import ClassStore, token_digest
from tests.cli.test_cli import autonomy
from tests.liveclass.lms_platform import AGS, CLIENT, COURSE, DEPLOYMENT, INSTRUCTOR, ISSUER, LEARNER, LTI, FakeLms
from tests.liveclass.test_server import GARAGE, call


def request(server, method: str, path: str, body: dict | None = None, cookie: str = "") -> tuple[int, dict, bytes]:
    """One request, redirects not followed: status, headers, body."""
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
    headers = {"Cookie": cookie} if cookie else {}
    data = None
    if body is not None:
        data = urllib.parse.urlencode(body).encode()
        headers["Content-Type"] = "application/x-www-form-urlencoded"
    connection.request(method, path, body=data, headers=headers)
    answer = connection.getresponse()
    result = answer.status, {k.lower(): v for k, v in answer.getheaders()}, answer.read()
    connection.close()
    return result


def login(server, **given: str) -> tuple[str, str, str]:
    """The LMS's login initiation: the state, the nonce and the state's cookie the tool answers with."""
    query = {"iss": ISSUER, "login_hint": "u-1001", "target_link_uri": "http://x/lti/launch", "client_id": CLIENT}
    status, headers, body = request(server, "GET", "/lti/login?" + urllib.parse.urlencode({**query, **given}))
    assert status == 302, body
    sent = urllib.parse.urlsplit(headers["location"])
    asked = dict(urllib.parse.parse_qsl(sent.query))
    assert f"{sent.scheme}://{sent.netloc}{sent.path}" == server.lti.platform.auth_url
    assert (asked["client_id"], asked["login_hint"], asked["response_mode"], asked["scope"]) == (
        CLIENT, "u-1001", "form_post", "openid"
    )  # fmt: skip
    assert asked["redirect_uri"].endswith("/lti/launch")
    cookie = headers["set-cookie"].split(";")[0]
    assert cookie == f"{state_cookie(asked['state'])}={asked['state']}" and "HttpOnly" in headers["set-cookie"]
    assert cookie.startswith("__Host-")
    assert "Path=/;" in headers["set-cookie"] + ";" and "Secure" in headers["set-cookie"]  # a __Host- cookie's
    return asked["state"], asked["nonce"], cookie


def launch(server, lms: FakeLms, **claims) -> tuple[int, dict, bytes]:
    state, nonce, cookie = login(server)
    return request(server, "POST", "/lti/launch", {"id_token": lms.id_token(nonce, **claims), "state": state}, cookie)


@pytest.fixture
def lms():
    made = FakeLms()
    yield made
    made.close()


def never_graded(*_: object, **__: object):
    """The grader of a class whose tests sign in and grade nothing (no grading process is started for them)."""
    raise AssertionError("nothing is graded here")


@pytest.fixture
def served(tmp_path, lms):
    store = ClassStore(tmp_path)
    codes = store.enrol([("s1", "Bob Jones")])
    store.set_setting(TEACHER_TOKEN, token_digest("teacher-token"))
    store.set_setting(lms_module.COURSE, json.dumps({"id": COURSE, "title": "Robotics 7"}))  # its teacher launched it
    server = ClassServer(
        GARAGE, store, tmp_path, port=0, grader=never_graded, lti=LtiTool(lms.platform(), ToolKey(tmp_path))
    )
    server.start()
    yield server, codes
    server.stop()
    store.close()


def code_of(headers: dict, page: str) -> str:
    match = re.fullmatch(rf"{re.escape(page)}(?:code=)?([A-Za-z0-9_-]+)", headers["location"])
    assert match, headers["location"]
    return match[1]


def test_a_learner_s_launch_signs_them_in_to_the_student_s_page_never_the_desk(served, lms):
    server, codes = served
    status, headers, _ = launch(server, lms)
    assert status == 303
    code = code_of(headers, "/#")
    status, me = call(server, "/api/me", code=code, method="GET")
    assert status == 200 and me["student"] == {"id": "1001", "name": "Ada Lovelace"}  # the institution's id
    assert call(server, "/api/class", code=code, method="GET")[0] == 401  # a learner never has the desk
    status, table = call(server, "/api/class", code="teacher-token", method="GET")
    assert [row["name"] for row in table["students"]] == ["Bob Jones", "Ada Lovelace"]
    assert table["students"][1]["signed_in"]
    # the LMS's keys were fetched once, and kept
    status, headers, _ = launch(server, lms, sub="s1", **{LTI + "lis": None, "name": "Cy"})
    assert status == 303 and lms.asked == 1
    # an LMS's own id is apart from the roster's: LMS user "s1" is not the roster's s1
    assert call(server, "/api/me", code=code_of(headers, "/#"), method="GET")[1]["student"]["id"] == "lms:s1"
    # codes keep working beside it
    assert call(server, "/api/me", code=codes["s1"], method="GET")[1]["student"]["id"] == "s1"


def test_an_instructor_s_launch_opens_the_desk(served, lms):
    server, _ = served
    status, headers, _ = launch(server, lms, sub="t-1", **{LTI + "roles": [INSTRUCTOR], LTI + "lis": None})
    assert status == 303
    token = code_of(headers, "/teacher#")
    assert call(server, "/api/class", code=token, method="GET")[0] == 200
    status, me = call(server, "/api/me", code=token, method="GET")
    assert status == 200 and "student" not in me  # the desk's: the exercise, as the teacher's token is answered
    assert call(server, "/api/run", {"mission": "x"}, token)[0] == 403  # and never a student's work
    status, table = call(server, "/api/class", code=token, method="GET")
    assert [row["id"] for row in table["students"]] == ["s1"]  # an instructor is not made a student


def forged():
    """A key pair of an attacker's, whose token names the LMS's key."""
    return rsa.generate_private_key(public_exponent=65537, key_size=2048)


@pytest.mark.parametrize(
    ("claims", "said"),
    [
        ({"key": "forged"}, "signature is not the LMS's"),
        ({"exp": int(time.time()) - 120}, "expired"),
        ({"iat": int(time.time()) + 600}, "from the future"),
        ({"aud": "another-client"}, "for another tool"),
        ({"iss": "https://other.example"}, "from another LMS"),
        ({LTI + "deployment_id": "deployment-9"}, "deployment 'deployment-9'"),
        ({LTI + "message_type": "LtiSubmissionReviewRequest"}, "LtiResourceLinkRequest"),
        ({LTI + "version": "1.1"}, "1.3.0"),
        ({"nonce": "not-the-login-s"}, "nonce is not the one"),
        ({"kid": "unknown-key"}, "does not publish"),
        ({LTI + "roles": None}, "no roles"),
        ({"exp": None}, "exp"),
        ({"sub": "", LTI + "lis": None}, "names nobody"),  # an empty id would be the desk's session
    ],
)
def test_a_launch_that_fails_a_check_is_refused_401_in_one_line(served, lms, claims, said):
    server, _ = served
    if claims.get("key") == "forged":
        claims = {"key": forged()}
    state, nonce, cookie = login(server)
    token = lms.id_token(claims.pop("nonce", nonce), **claims)
    status, _, body = request(server, "POST", "/lti/launch", {"id_token": token, "state": state}, cookie)
    error = json.loads(body)["error"]
    assert status == 401 and error.startswith("LTI launch refused: ") and said in error, error
    assert "\n" not in error and len(error) < 200


def test_a_replayed_launch_a_stolen_state_and_an_unsigned_token_are_refused(served, lms):
    server, _ = served
    state, nonce, cookie = login(server)
    form = {"id_token": lms.id_token(nonce), "state": state}
    assert request(server, "POST", "/lti/launch", form, cookie)[0] == 303
    status, _, body = request(server, "POST", "/lti/launch", form, cookie)  # the same launch again
    assert status == 401 and "state was used already" in json.loads(body)["error"]
    state, nonce, cookie = login(server)  # a state taken to another browser (which has no cookie of it)
    status, _, body = request(server, "POST", "/lti/launch", {"id_token": lms.id_token(nonce), "state": state})
    assert status == 401 and "not this browser's" in json.loads(body)["error"]
    state, nonce, cookie = login(server)  # HS256, keyed with what anyone can read: the LMS's public key
    public = lms.jwks["keys"][0]["n"]  # what anyone can read (its modulus), as an HMAC key
    unsigned = jwt.encode({"nonce": nonce}, public, algorithm="HS256", headers={"kid": lms.kid})
    status, _, body = request(server, "POST", "/lti/launch", {"id_token": unsigned, "state": state}, cookie)
    assert status == 401 and "LTI 1.3 signs with RS256" in json.loads(body)["error"]
    state, nonce, cookie = login(server)
    status, _, body = request(server, "POST", "/lti/launch", {"id_token": "not a token", "state": state}, cookie)
    assert status == 401 and "not a signed token" in json.loads(body)["error"]


def test_a_login_from_another_lms_or_without_its_hint_is_refused_and_a_huge_form_too(served, lms):
    server, _ = served
    for given, said in (({"iss": "https://evil.example"}, "not from this class's LMS"), ({"login_hint": ""}, "hint")):
        query = {"iss": ISSUER, "login_hint": "u", **given}
        status, _, body = request(server, "GET", "/lti/login?" + urllib.parse.urlencode(query))
        assert status == 401 and said in json.loads(body)["error"]
    status, _, _ = request(server, "POST", "/lti/launch", {"id_token": "x" * 100_000, "state": "s"})
    assert status == 413


def test_the_tool_s_key_is_published_and_kept_the_teacher_s_alone(served, tmp_path):
    server, _ = served
    status, _, body = request(server, "GET", "/lti/jwks")
    (key,) = json.loads(body)["keys"]
    assert status == 200 and (key["kty"], key["alg"], key["use"]) == ("RSA", "RS256", "sig") and "d" not in key
    assert key["kid"] == ToolKey(tmp_path).kid  # the same key, read again
    assert stat.S_IMODE(os.stat(tmp_path / "lti" / "tool-key.pem").st_mode) == 0o600
    # the pages may be framed by the LMS (which launches the tool in a frame), and by nobody else
    status, headers, _ = request(server, "GET", "/")
    assert f"frame-ancestors {ISSUER}" in headers["content-security-policy"]


def test_lti_config_prints_what_the_lms_admin_pastes_and_keeps_the_lms_s_details(tmp_path):
    folder = tmp_path / "class"
    shown = autonomy("class", "lti-config", "--dir", str(folder), "--public-url", "https://class.school.example")
    assert shown.returncode == 0, shown.stderr
    for line in ("Tool URL:", "Login URL (OIDC initiation):", "Redirect URI:", "Public keyset URL (JWKS):"):
        assert re.search(rf"^  {re.escape(line)} +https://class\.school\.example/lti/", shown.stdout, re.M), line
    canvas = json.loads(shown.stdout[shown.stdout.index("{") :])
    assert canvas["oidc_initiation_url"] == "https://class.school.example/lti/login"
    assert canvas["public_jwk_url"] == "https://class.school.example/lti/jwks"
    placements = canvas["extensions"][0]["settings"]["placements"]
    assert {(p["placement"], p["message_type"]) for p in placements} == {
        ("link_selection", "LtiDeepLinkingRequest"), ("assignment_selection", "LtiDeepLinkingRequest")
    }  # fmt: skip
    given = ["--issuer", ISSUER, "--client-id", CLIENT, "--auth-url", f"{ISSUER}/auth", "--jwks-url", f"{ISSUER}/k"]
    partial = autonomy("class", "lti-config", "--dir", str(folder), *given)
    assert partial.returncode == 2 and len(partial.stderr.strip().splitlines()) == 1
    assert "--deployment-id" in partial.stderr
    whole = autonomy("class", "lti-config", "--dir", str(folder), *given, "--deployment-id", DEPLOYMENT)
    assert whole.returncode == 0 and f"The LMS: {ISSUER}, client id {CLIENT}" in whole.stdout
    kept = json.loads((folder / "lti" / "platform.json").read_text())
    assert kept["deployment_ids"] == [DEPLOYMENT] and kept["client_id"] == CLIENT
    assert stat.S_IMODE(os.stat(folder / "lti" / "platform.json").st_mode) == 0o600
    bad = autonomy("class", "lti-config", "--dir", str(folder), "--public-url", "ftp://x")
    assert bad.returncode == 2 and "https://" in bad.stderr and "Traceback" not in bad.stderr


def test_a_class_served_with_its_lms_says_so_and_a_broken_lms_file_is_one_line(tmp_path):
    from tests.liveclass.test_class_cli import serve

    (tmp_path / "roster.csv").write_text("id,name\n1001,Ada Lovelace\n")
    folder = tmp_path / "class"
    (folder / "lti").mkdir(parents=True)
    (folder / "lti" / "platform.json").write_text("{not json")
    broken = autonomy("class", "serve", "garage", "--roster", str(tmp_path / "roster.csv"), "--dir", str(folder))
    assert broken.returncode == 2 and "cannot read the LMS's settings" in broken.stderr
    assert len(broken.stderr.strip().splitlines()) == 1
    given = ["--issuer", ISSUER, "--client-id", CLIENT, "--auth-url", f"{ISSUER}/auth", "--jwks-url", f"{ISSUER}/k"]
    assert autonomy("class", "lti-config", "--dir", str(folder), *given, "--deployment-id", DEPLOYMENT).returncode == 0
    process, port, _ = serve(tmp_path)
    try:
        said = process.said + process.stderr.readline() + process.stderr.readline() + process.stderr.readline()
        assert f"LMS: {ISSUER} launches the class (LTI 1.3, client id {CLIENT})" in said, said
        connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        connection.request("GET", "/lti/jwks")
        assert connection.getresponse().status == 200
    finally:
        process.terminate()
        process.communicate(timeout=30)


def test_a_unique_subject_per_launch_keeps_each_learner_apart(served, lms):
    server, _ = served
    seen = set()
    for _ in range(3):
        subject = str(uuid.uuid4())
        status, headers, _ = launch(server, lms, sub=subject, **{LTI + "lis": None, "name": subject[:8]})
        assert status == 303
        status, me = call(server, "/api/me", code=code_of(headers, "/#"), method="GET")
        seen.add(me["student"]["id"])
    assert len(seen) == 3


def refusal(answer: tuple[int, dict, bytes]) -> str:
    status, _, body = answer
    assert status == 401, (status, body)
    return json.loads(body)["error"]


def test_a_class_is_one_course_s_its_teacher_s_first_launch_ties_it_and_no_other_course_gets_in(tmp_path, lms):
    store = ClassStore(tmp_path)
    server = ClassServer(
        GARAGE, store, tmp_path, port=0, grader=never_graded, lti=LtiTool(lms.platform(), ToolKey(tmp_path))
    )
    server.start()
    try:
        # before its teacher opened it, no learner gets in: a learner of another course could tie it to theirs
        assert "its teacher opens the link first" in refusal(launch(server, lms))
        other = {LTI + "context": {"id": "course-9", "title": "Cooking"}}
        status, headers, _ = launch(server, lms, sub="t-1", **{LTI + "roles": [INSTRUCTOR], LTI + "lis": None})
        assert status == 303  # the class is course-7's from now on
        assert launch(server, lms)[0] == 303
        assert "course 'course-9', not this class's ('course-7')" in refusal(launch(server, lms, **other))
        teacher = {LTI + "roles": [INSTRUCTOR], LTI + "lis": None, "sub": "t-2"}
        assert "not this class's" in refusal(launch(server, lms, **teacher, **other))  # nor its teacher
        assert "names no course" in refusal(launch(server, lms, **{LTI + "context": None}))
        status, said = call(server, "/api/lms", code=code_of(headers, "/teacher#"), method="GET")
        assert status == 200 and said["course"] == {"id": COURSE, "title": "Robotics 7"}
        assert said["instructors"] == ["Ada Lovelace"]
    finally:
        server.stop()
        store.close()


def test_who_a_learner_is_stays_what_the_lms_first_said_and_nobody_takes_another_s_place(served, lms):
    server, codes = served
    status, headers, _ = launch(server, lms)  # u-1001, the school's 1001
    assert call(server, "/api/me", code=code_of(headers, "/#"), method="GET")[1]["student"]["id"] == "1001"
    # another LMS person whose school id the LMS gives as 1001 (a typo, or an attack) does not become them
    said = refusal(launch(server, lms, sub="u-666", name="Mallory"))
    assert "student '1001' is another LMS person's" in said
    # nor can an LMS person become the roster's s1 once an LMS person is tied to it
    assert launch(server, lms, sub="u-2", **{LTI + "lis": {"person_sourcedid": "s1"}, "name": "Bob"})[0] == 303
    assert "another LMS person's" in refusal(
        launch(server, lms, sub="u-3", **{LTI + "lis": {"person_sourcedid": "s1"}})
    )
    # u-1001 stays 1001, whatever school id the LMS later gives
    status, headers, _ = launch(server, lms, **{LTI + "lis": {"person_sourcedid": "9999"}})
    assert call(server, "/api/me", code=code_of(headers, "/#"), method="GET")[1]["student"]["id"] == "1001"
    assert call(server, "/api/me", code=codes["s1"], method="GET")[1]["student"]["id"] == "s1"  # codes still


def test_a_junk_launch_costs_no_fetch_and_a_flood_of_logins_pushes_out_no_real_one(served, lms):
    server, _ = served
    state, nonce, cookie = login(server)  # a real login, before the flood
    for _ in range(300):  # what 4,096 kept states once let push out; a state is kept by nobody now
        login(server)
    made_up = "x" * 20 + "." + str(int(time.time()) + 60) + "." + "0" * 32
    said = refusal(request(server, "POST", "/lti/launch", {"id_token": "junk", "state": made_up},
                           f"{state_cookie(made_up)}={made_up}"))  # fmt: skip
    assert "state this tool did not give" in said and lms.asked == 0  # refused before any key was asked for
    form = {"id_token": lms.id_token(nonce), "state": state}
    assert request(server, "POST", "/lti/launch", form, cookie)[0] == 303 and lms.asked == 1


def test_an_lms_whose_keys_cannot_be_had_is_asked_again_only_a_while_later(tmp_path):
    store = ClassStore(tmp_path)
    store.set_setting(lms_module.COURSE, json.dumps({"id": COURSE}))
    down = FakeLms()
    down.close()  # its port closed
    server = ClassServer(
        GARAGE, store, tmp_path, port=0, grader=never_graded, lti=LtiTool(down.platform(), ToolKey(tmp_path))
    )
    server.start()
    try:
        assert "keys could not be had" in refusal(launch(server, down))
        assert "keys could not be had" in refusal(launch(server, down))  # at once: not fetched again
        assert server.lti._unfetched is not None
    finally:
        server.stop()
        store.close()


def test_a_key_the_lms_adds_is_fetched_once_and_a_token_of_another_party_or_an_endless_time_is_refused(served, lms):
    server, _ = served
    assert launch(server, lms)[0] == 303 and lms.asked == 1
    new = forged()  # the LMS's new key, published beside the old one
    public = json.loads(jwt.algorithms.RSAAlgorithm.to_jwk(new.public_key()))
    lms.jwks["keys"].append({**public, "kid": "lms-key-2", "alg": "RS256", "use": "sig"})
    kept, until = server.lti._jwks
    server.lti._jwks = (kept, until - 30)  # fetched 30 s ago
    assert launch(server, lms, key=new, kid="lms-key-2", sub="u-5", **{LTI + "lis": None})[0] == 303
    assert lms.asked == 2
    assert "does not publish" in refusal(launch(server, lms, kid="lms-key-3"))  # fetched again only a while later
    assert lms.asked == 2
    assert "azp" in refusal(launch(server, lms, azp="another-client"))
    assert "exp is not a time" in refusal(launch(server, lms, exp=float("inf")))
    lms.jwks["keys"][0]["use"] = "enc"  # a key for encryption signs nothing
    server.lti._jwks = (lms.jwks, until)
    assert "does not publish" in refusal(launch(server, lms))


def test_a_course_s_short_instructor_role_opens_the_desk_and_a_teacher_elsewhere_in_the_school_does_not(served, lms):
    server, _ = served
    status, headers, _ = launch(server, lms, sub="t-9", **{LTI + "roles": ["Instructor"], LTI + "lis": None})
    assert status == 303 and headers["location"].startswith("/teacher#")
    school = ["http://purl.imsglobal.org/vocab/lis/v2/institution/person#Instructor", LEARNER]
    status, headers, _ = launch(server, lms, sub="u-8", **{LTI + "roles": school, LTI + "lis": None})
    assert status == 303 and headers["location"].startswith("/#code=")


def test_an_lms_file_with_odd_keys_is_one_line(tmp_path):
    folder = tmp_path / "class"
    (folder / "lti").mkdir(parents=True)
    settings = {"issuer": ISSUER, "client_id": CLIENT, "auth_url": f"{ISSUER}/a", "deployment_ids": [DEPLOYMENT],
                "jwks": ["not", "a", "jwks"]}  # fmt: skip
    (folder / "lti" / "platform.json").write_text(json.dumps(settings))
    (tmp_path / "roster.csv").write_text("id,name\n1001,Ada Lovelace\n")
    broken = autonomy("class", "serve", "garage", "--roster", str(tmp_path / "roster.csv"), "--dir", str(folder))
    assert broken.returncode == 2 and "jwks not as lti-config writes them" in broken.stderr, broken.stderr
    assert len(broken.stderr.strip().splitlines()) == 1


def test_lti_config_ties_the_class_to_a_course_and_keeps_its_address(tmp_path):
    folder = tmp_path / "class"
    alone = autonomy("class", "lti-config", "--dir", str(folder), "--course-id", "course-7")
    assert alone.returncode == 2 and "give the LMS first" in alone.stderr
    given = ["--issuer", ISSUER, "--client-id", CLIENT, "--auth-url", f"{ISSUER}/auth", "--jwks-url", f"{ISSUER}/k",
             "--deployment-id", DEPLOYMENT, "--token-url", f"{ISSUER}/token"]  # fmt: skip
    made = autonomy("class", "lti-config", "--dir", str(folder), *given, "--course-id", COURSE,
                    "--public-url", "https://class.school.example")  # fmt: skip
    assert made.returncode == 0 and f"the class is course {COURSE}; roster and marks by {ISSUER}/token" in made.stdout
    kept = json.loads((folder / "lti" / "platform.json").read_text())
    assert kept["course_id"] == COURSE and kept["public_url"] == "https://class.school.example"
    again = autonomy("class", "lti-config", "--dir", str(folder), *given)  # the LMS given again: what it tied kept
    assert again.returncode == 0 and json.loads((folder / "lti" / "platform.json").read_text())["course_id"] == COURSE


def test_the_lms_s_page_may_post_the_launch_and_nothing_else_and_the_public_name_is_served(tmp_path, lms):
    store = ClassStore(tmp_path)
    store.set_setting(lms_module.COURSE, json.dumps({"id": COURSE}))
    tool = LtiTool(lms.platform(), ToolKey(tmp_path))
    server = ClassServer(GARAGE, store, tmp_path, port=0, grader=never_graded, lti=tool,
                         public_url="https://class.school.example")  # fmt: skip
    server.start()
    try:

        def asked(path: str, method: str = "POST", **headers: str) -> int:
            connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=30)
            connection.request(method, path, body=b"" if method == "POST" else None, headers=headers)
            status = connection.getresponse().status
            connection.close()
            return status

        lms_page = {"Origin": "https://lms.school.example"}
        assert asked("/lti/launch", **lms_page) == 401  # the LMS's page may post it (its checks are its own)
        assert asked("/api/deadline", **lms_page) == 403 and asked("/api/run", **lms_page) == 403  # nothing else
        assert asked("/lti/jwks", "GET", Host="class.school.example") == 200  # behind the school's proxy
        assert asked("/lti/jwks", "GET", Host="evil.example") == 403
    finally:
        server.stop()
        store.close()


def test_a_teacher_adds_the_class_to_the_course_by_deep_linking_and_a_learner_cannot(served, lms):
    server, _ = served
    teacher = {LTI + "roles": [INSTRUCTOR], LTI + "lis": None, "sub": "t-1"}
    status, headers, body = launch(server, lms, **teacher, **lms.deep_linking())
    page = body.decode()
    assert status == 200 and headers["content-type"].startswith("text/html")
    assert f"form-action {lms.base}" in headers["content-security-policy"]
    assert f"frame-ancestors {ISSUER}" in headers["content-security-policy"] and "<script" not in page
    forms = re.findall(r'<form id="(\w+)" method="post" action="([^"]+)">\s*<input type="hidden" name="JWT" '
                       r'value="([^"]+)">', page)  # fmt: skip
    back = f"{lms.base}/deep-link-return"
    assert [(name, action) for name, action, _ in forms] == [("add", back), ("none", back)]
    key = jwt.PyJWK(ToolKey(server.folder).jwks()["keys"][0]).key
    added, none = (
        jwt.decode(token, key, algorithms=["RS256"], audience=ISSUER, issuer=CLIENT) for _, _, token in forms
    )
    dl = "https://purl.imsglobal.org/spec/lti-dl/claim/"
    assert added[LTI + "message_type"] == "LtiDeepLinkingResponse" and added[LTI + "deployment_id"] == DEPLOYMENT
    assert added[dl + "data"] == "lms-data-7"  # given back as the LMS gave it
    (item,) = added[dl + "content_items"]
    assert item["type"] == "ltiResourceLink" and item["url"].endswith("/lti/launch") and item["title"] == GARAGE.title
    assert item["lineItem"] == {"scoreMaximum": GARAGE.max_points, "label": GARAGE.title,
                                "resourceId": "autonomy:garage", "tag": "autonomy"}  # fmt: skip
    assert none[dl + "content_items"] == []
    assert "only a teacher of the course" in refusal(launch(server, lms, **lms.deep_linking()))
    settings = "https://purl.imsglobal.org/spec/lti-dl/claim/deep_linking_settings"
    assert "without its settings" in refusal(launch(server, lms, **teacher, **{**lms.deep_linking(), settings: None}))


def test_a_form_in_pieces_two_tabs_logins_a_learner_s_other_link_and_an_overlong_sub(served, lms):
    import socket

    server, _ = served
    state, nonce, cookie = login(server)
    body = urllib.parse.urlencode({"id_token": lms.id_token(nonce), "state": state}).encode()
    with socket.create_connection(("127.0.0.1", server.port), timeout=30) as sock:  # the form in two pieces
        head = (f"POST /lti/launch HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\nCookie: {cookie}\r\n"
                f"Content-Type: application/x-www-form-urlencoded\r\nContent-Length: {len(body)}\r\n"
                "Connection: close\r\n\r\n")  # fmt: skip
        sock.sendall(head.encode() + body[:100])
        time.sleep(0.3)
        sock.sendall(body[100:])
        answer = sock.makefile("rb").readline()
    assert b" 303 " in answer, answer
    # two tabs' logins in one browser: each keeps its cookie, and both launches hold
    first, second = login(server), login(server)
    both = f"{first[2]}; {second[2]}"
    for state, nonce, _ in (second, first):
        form = {"id_token": lms.id_token(nonce), "state": state}
        assert request(server, "POST", "/lti/launch", form, both)[0] == 303
    # a learner's launch of another graded link does not send the class's marks to its column
    own = {AGS: {"lineitems": f"{lms.base}/li", "lineitem": f"{lms.base}/li/1"}}
    launch(server, lms, sub="t-1", **{LTI + "roles": [INSTRUCTOR], LTI + "lis": None, **own})
    launch(server, lms, **{AGS: {"lineitems": f"{lms.base}/li", "lineitem": f"{lms.base}/li/99"}})
    assert server.store.setting(lms_module.LINK_LINEITEM_URL) == f"{lms.base}/li/1"
    assert "255 characters" in refusal(launch(server, lms, sub="u" * 256, **{LTI + "lis": None}))


def test_the_pages_may_be_framed_by_the_lms_s_own_pages_where_they_are_not_its_issuer_s(tmp_path, lms):
    folder = tmp_path / "class"
    given = ["--issuer", ISSUER, "--client-id", CLIENT, "--auth-url", f"{ISSUER}/auth", "--jwks-url", f"{ISSUER}/k",
             "--deployment-id", DEPLOYMENT]  # fmt: skip
    bad = autonomy("class", "lti-config", "--dir", str(folder), *given, "--frame-origin", "https://x.example/path")
    assert bad.returncode == 2 and "an origin" in bad.stderr
    made = autonomy("class", "lti-config", "--dir", str(folder), *given, "--frame-origin", "https://school.example")
    assert made.returncode == 0, made.stderr
    from autonomy.liveclass.lti import read_platform

    store = ClassStore(folder)
    server = ClassServer(GARAGE, store, folder, port=0, grader=never_graded,
                         lti=LtiTool(read_platform(folder), ToolKey(folder)))  # fmt: skip
    server.start()
    try:
        status, headers, _ = request(server, "GET", "/")
        assert f"frame-ancestors {ISSUER} https://school.example" in headers["content-security-policy"]
    finally:
        server.stop()
        store.close()


def test_lti_config_run_again_keeps_what_it_kept_unties_a_launch_s_course_and_names_what_is_missing(tmp_path, lms):
    folder = tmp_path / "class"
    given = ["--issuer", ISSUER, "--client-id", CLIENT, "--auth-url", f"{ISSUER}/auth", "--jwks-url", f"{ISSUER}/k",
             "--deployment-id", DEPLOYMENT]  # fmt: skip
    made = autonomy("class", "lti-config", "--dir", str(folder), *given, "--public-url", "https://robots.school.example",
                    "--frame-origin", "https://school.example")  # fmt: skip
    assert made.returncode == 0, made.stderr
    again = autonomy("class", "lti-config", "--dir", str(folder), *given)  # the LMS given again: nothing lost
    assert "Tool URL:                      https://robots.school.example/lti/launch" in again.stdout
    assert "answers at https://robots.school.example; its pages may be framed by" in again.stdout
    assert "https://school.example" in again.stdout
    for bad, said in (
        (["--public-url", "https://robots .school.example"], "no space"),
        (["--public-url", "https://robots.school.example:99999"], "port"),
        (["--public-url", "http://robots.school.example"], "HTTPS"),
        (["--issuer", ISSUER, "--client-id", CLIENT], "--auth-url, --jwks-url, --deployment-id missing"),
    ):
        shown = autonomy("class", "lti-config", "--dir", str(tmp_path / "other"), *bad)  # fmt: skip
        assert shown.returncode == 2 and said in shown.stderr and "Traceback" not in shown.stderr, shown.stderr
        assert len(shown.stderr.strip().splitlines()) == 1
    alone = autonomy("class", "lti-config", "--dir", str(tmp_path / "other"), "--frame-origin", "https://a.example")
    assert alone.returncode == 2 and "give the LMS first" in alone.stderr
    # a class a teacher's launch tied to a course is let go by --course-id ''
    store = ClassStore(folder)
    store.set_setting(lms_module.COURSE, json.dumps({"id": COURSE}))
    store.close()
    assert autonomy("class", "lti-config", "--dir", str(folder), "--course-id", "").returncode == 0
    store = ClassStore(folder)
    assert json.loads(store.setting(lms_module.COURSE, "{}")) == {}
    store.close()


def test_lms_forms_that_never_end_are_read_within_a_budget_of_their_own_and_hold_back_no_student(served, lms):
    import socket

    from autonomy.liveclass.server import LTI_BODIES_READ_BYTES, LTI_MOST_BYTES

    server, codes = served
    server.bodies_read_bytes = LTI_BODIES_READ_BYTES  # the students' budget no larger than the forms' alone
    held = []
    try:
        for _ in range(LTI_BODIES_READ_BYTES // LTI_MOST_BYTES):  # forms that never end, each declared at the most
            sock = socket.create_connection(("127.0.0.1", server.port), timeout=30)
            head = f"POST /lti/launch HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\nContent-Length: {LTI_MOST_BYTES}\r\n"
            sock.sendall((head + "Content-Type: application/x-www-form-urlencoded\r\n\r\nid_token=").encode())
            held.append(sock)
        time.sleep(0.5)  # each is being read
        status, _, body = request(server, "POST", "/lti/launch", {"id_token": "x", "state": "y"})
        assert status == 503 and "many sign-ins at once" in json.loads(body)["error"]
        assert call(server, "/api/check", {"mission": "mission: m\ntree: stop\n"}, codes["s1"])[0] == 200
    finally:
        for sock in held:
            sock.close()
