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
import threading
import time
import urllib.parse
import uuid

import jwt
import pytest
from cryptography.hazmat.primitives.asymmetric import rsa

from autonomy.liveclass.lti import LtiTool, Platform, ToolKey
from autonomy.liveclass.server import TEACHER_TOKEN, ClassServer
from autonomy.liveclass.store import ClassStore, token_digest
from tests.cli.test_cli import autonomy
from tests.liveclass.test_server import GARAGE, call

ISSUER = "https://lms.school.example"
CLIENT = "client-42"
DEPLOYMENT = "deployment-1"
LTI = "https://purl.imsglobal.org/spec/lti/claim/"
LEARNER = "http://purl.imsglobal.org/vocab/lis/v2/membership#Learner"
INSTRUCTOR = "http://purl.imsglobal.org/vocab/lis/v2/membership#Instructor"


class FakeLms:
    """An LMS as the tool sees it: a key pair whose public half it publishes (over HTTP), and id_tokens it signs."""

    def __init__(self) -> None:
        self.key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
        self.kid = "lms-key-1"
        public = json.loads(jwt.algorithms.RSAAlgorithm.to_jwk(self.key.public_key()))
        self.jwks = {"keys": [{**public, "kid": self.kid, "alg": "RS256", "use": "sig"}]}
        self.asked = 0
        lms = self

        class Keys(http.server.BaseHTTPRequestHandler):
            def do_GET(self) -> None:  # noqa: N802 - http.server's name
                lms.asked += 1
                body = json.dumps(lms.jwks).encode()
                self.send_response(200)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *_: object) -> None:
                pass

        self.http = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Keys)
        threading.Thread(target=self.http.serve_forever, args=(0.02,), daemon=True).start()
        self.jwks_url = f"http://127.0.0.1:{self.http.server_address[1]}/keys"

    def platform(self) -> Platform:
        return Platform(ISSUER, CLIENT, f"{ISSUER}/auth", f"{ISSUER}/token", self.jwks_url, (DEPLOYMENT,))

    def id_token(self, nonce: str, key=None, kid: str | None = None, algorithm: str = "RS256", **claims) -> str:
        now = int(time.time())
        body = {
            "iss": ISSUER,
            "aud": CLIENT,
            "sub": "u-1001",
            "iat": now,
            "exp": now + 300,
            "nonce": nonce,
            "name": "Ada Lovelace",
            LTI + "deployment_id": DEPLOYMENT,
            LTI + "message_type": "LtiResourceLinkRequest",
            LTI + "version": "1.3.0",
            LTI + "resource_link": {"id": "link-garage"},
            LTI + "roles": [LEARNER],
            LTI + "lis": {"person_sourcedid": "1001"},
        }
        body.update(claims)
        body = {k: v for k, v in body.items() if v is not None}
        return jwt.encode(body, key or self.key, algorithm=algorithm, headers={"kid": kid or self.kid})


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
    assert f"{sent.scheme}://{sent.netloc}{sent.path}" == f"{ISSUER}/auth"
    assert (asked["client_id"], asked["login_hint"], asked["response_mode"], asked["scope"]) == (
        CLIENT, "u-1001", "form_post", "openid"
    )  # fmt: skip
    assert asked["redirect_uri"].endswith("/lti/launch")
    cookie = headers["set-cookie"].split(";")[0]
    assert cookie == f"autonomy-lti-state={asked['state']}" and "HttpOnly" in headers["set-cookie"]
    return asked["state"], asked["nonce"], cookie


def launch(server, lms: FakeLms, **claims) -> tuple[int, dict, bytes]:
    state, nonce, cookie = login(server)
    return request(server, "POST", "/lti/launch", {"id_token": lms.id_token(nonce, **claims), "state": state}, cookie)


@pytest.fixture
def lms():
    made = FakeLms()
    yield made
    made.http.shutdown()


def never_graded(*_: object, **__: object):
    """The grader of a class whose tests sign in and grade nothing (no grading process is started for them)."""
    raise AssertionError("nothing is graded here")


@pytest.fixture
def served(tmp_path, lms):
    store = ClassStore(tmp_path)
    codes = store.enrol([("s1", "Bob Jones")])
    store.set_setting(TEACHER_TOKEN, token_digest("teacher-token"))
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
        ({LTI + "message_type": "LtiDeepLinkingRequest"}, "LtiResourceLinkRequest"),
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
    assert status == 401 and "state this tool did not give, or gave and saw used" in json.loads(body)["error"]
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
