"""An LMS run in the test process, as an LTI 1.3 tool sees one: its own RSA key, its keys published over HTTP on
loopback, id_tokens signed with PyJWT, and LTI Advantage's services: an OAuth 2 token address that checks the
tool's signed assertion against the tool's published keys, a course's roster (Names and Roles, in pages with
``Link: rel="next"``), its line items and their scores (Assignment and Grades). It can go down (its port
closed: connections refused) and come back on the same port."""

from __future__ import annotations

import html
import http.server
import json
import secrets
import threading
import time
import urllib.parse
import urllib.request

import jwt
from cryptography.hazmat.primitives.asymmetric import rsa

from autonomy.liveclass.lti import Platform

ISSUER = "https://lms.school.example"
CLIENT = "client-42"
DEPLOYMENT = "deployment-1"
COURSE = "course-7"
LTI = "https://purl.imsglobal.org/spec/lti/claim/"
LEARNER = "http://purl.imsglobal.org/vocab/lis/v2/membership#Learner"
INSTRUCTOR = "http://purl.imsglobal.org/vocab/lis/v2/membership#Instructor"
NRPS = "https://purl.imsglobal.org/spec/lti-nrps/claim/namesroleservice"
AGS = "https://purl.imsglobal.org/spec/lti-ags/claim/endpoint"
PAGE = 100


class FakeLms:
    """An LMS: a key pair whose public half it publishes, id_tokens it signs, and its roster and gradebook.

    Args:
        tool_jwks_url: Where the tool publishes its keys (the token address checks assertions with them); None:
            the roster and gradebook are not served.
    """

    def __init__(self, tool_jwks_url: str | None = None) -> None:
        self.key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
        self.kid = "lms-key-1"
        public = json.loads(jwt.algorithms.RSAAlgorithm.to_jwk(self.key.public_key()))
        self.jwks = {"keys": [{**public, "kid": self.kid, "alg": "RS256", "use": "sig"}]}
        self.asked = 0
        self.tool_jwks_url = tool_jwks_url
        #: The course's members (NRPS's entries), its line items by number, and the scores each was sent.
        self.members: list[dict] = []
        self.items: dict[int, dict] = {}
        self.scores: dict[int, list[dict]] = {}
        self.tokens: dict[str, str] = {}  # token: its scope
        self.names: dict[str, str] = {"t-1": "Grace Hopper"}  # the names of those who follow the course's link
        self.deep_links: list[dict] = []  # the tool's deep-linking answers, checked
        self.delay_s = 0.0  # how long each answer takes to begin (an LMS far away)
        self.moved = False  # the score address answers with a redirect
        self.broken_items = False  # the line items' address answers with what is not JSON
        self.asked_for: list[str] = []  # each request's method and path
        self.lock = threading.Lock()
        self.http = self._serve(0)
        self.port = self.http.server_address[1]
        self.base = f"http://127.0.0.1:{self.port}"
        self.jwks_url = f"{self.base}/keys"

    # ------------------------------------------------------------------ up and down

    def _serve(self, port: int) -> http.server.ThreadingHTTPServer:
        lms = self

        class Handler(http.server.BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def do_GET(self) -> None:  # noqa: N802 - http.server's name
                lms._answer(self, "GET")

            def do_POST(self) -> None:  # noqa: N802
                lms._answer(self, "POST")

            def log_message(self, *_: object) -> None:
                pass

        served = http.server.ThreadingHTTPServer(("127.0.0.1", port), Handler)
        served.daemon_threads = True
        threading.Thread(target=served.serve_forever, args=(0.02,), daemon=True).start()
        return served

    def down(self) -> None:
        """Its port closed: a connection to it is refused."""
        self.http.shutdown()
        self.http.server_close()

    def up(self) -> None:
        """Back, on the same port."""
        self.http = self._serve(self.port)

    def close(self) -> None:
        self.down()

    # ------------------------------------------------------------------ what the tool is told

    def platform(self) -> Platform:
        return Platform(ISSUER, CLIENT, f"{self.base}/auth", f"{self.base}/token", self.jwks_url, (DEPLOYMENT,))

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
            LTI + "context": {"id": COURSE, "title": "Robotics 7"},
            NRPS: {"context_memberships_url": f"{self.base}/courses/7/members", "service_versions": ["2.0"]},
            AGS: {"scope": [], "lineitems": f"{self.base}/courses/7/lineitems"},
        }
        body.update(claims)
        body = {k: v for k, v in body.items() if v is not None}
        return jwt.encode(body, key or self.key, algorithm=algorithm, headers={"kid": kid or self.kid})

    def deep_linking(self) -> dict:
        """A deep-linking request's claims (the teacher's "add external tool", in place of a link's launch)."""
        settings = {"deep_link_return_url": f"{self.base}/deep-link-return", "accept_types": ["ltiResourceLink"],
                    "accept_presentation_document_targets": ["iframe", "window"], "data": "lms-data-7"}  # fmt: skip
        return {
            LTI + "message_type": "LtiDeepLinkingRequest",
            LTI + "resource_link": None,
            "https://purl.imsglobal.org/spec/lti-dl/claim/deep_linking_settings": settings,
        }

    def enrol(self, count: int, start: int = 0) -> None:
        """``count`` learners in the course (and its instructor)."""
        self.members = [
            {"user_id": f"u-{k}", "name": f"Student {k}", "lis_person_sourcedid": f"{k:05d}", "roles": [LEARNER],
             "status": "Active"}
            for k in range(start, start + count)
        ] + [{"user_id": "t-1", "name": "Grace Hopper", "roles": [INSTRUCTOR], "status": "Active"}]  # fmt: skip

    def sent(self) -> list[dict]:
        """Every score sent, to any line item."""
        with self.lock:
            return [score for scores in self.scores.values() for score in scores]

    # ------------------------------------------------------------------ the answers

    def _answer(self, handler: http.server.BaseHTTPRequestHandler, method: str) -> None:
        parts = urllib.parse.urlsplit(handler.path)
        length = int(handler.headers.get("Content-Length") or 0)
        body = handler.rfile.read(length) if length else b""
        with self.lock:
            self.asked_for.append(f"{method} {parts.path}")
        if self.delay_s:  # an LMS far away
            time.sleep(self.delay_s)
        if parts.path == "/keys":
            self.asked += 1
            return _send(handler, 200, self.jwks)
        query = dict(urllib.parse.parse_qsl(parts.query))
        if parts.path == "/course":  # a person follows the course's link: the tool's login, as LTI starts it
            login = {"iss": ISSUER, "login_hint": query["who"], "target_link_uri": f"{query['tool']}lti/launch",
                     "client_id": CLIENT, "lti_message_hint": query.get("hint", "link-garage")}  # fmt: skip
            return _send(handler, 302, None, {"Location": f"{query['tool']}lti/login?{urllib.parse.urlencode(login)}"})
        if parts.path == "/auth":  # the LMS's answer to the login: the browser posts the id_token to the tool
            who = query["login_hint"]
            claims = {"sub": who, "name": self.names.get(who, who)}
            if who.startswith("t-"):
                claims |= {LTI + "roles": [INSTRUCTOR], LTI + "lis": None}
            else:
                school = [m.get("lis_person_sourcedid") for m in self.members if m["user_id"] == who]
                claims[LTI + "lis"] = {"person_sourcedid": school[0] if school else who}
                claims["name"] = self.names.get(who) or next(
                    (m["name"] for m in self.members if m["user_id"] == who), who
                )
            if query.get("lti_message_hint") == "deep":  # the teacher's "add external tool"
                claims |= self.deep_linking()
            token = self.id_token(query["nonce"], **claims)
            page = (
                '<!doctype html><html lang="en"><title>LMS</title><link rel="icon" href="data:,"><body>'
                '<form method="post" action="'
                + html.escape(query["redirect_uri"]) + '"><input type="hidden" name="id_token" value="' + token
                + '"><input type="hidden" name="state" value="' + html.escape(query["state"])
                + '"></form><script>document.forms[0].submit()</script></body></html>'
            )  # fmt: skip
            body = page.encode()
            handler.send_response(200)
            handler.send_header("Content-Type", "text/html; charset=utf-8")
            handler.send_header("Content-Length", str(len(body)))
            handler.end_headers()
            handler.wfile.write(body)
            return None
        if parts.path == "/deep-link-return" and method == "POST":  # the tool's answer: the link to add, checked
            with urllib.request.urlopen(self.tool_jwks_url, timeout=10) as answer:  # noqa: S310 - loopback
                (key,) = json.load(answer)["keys"]
            token = dict(urllib.parse.parse_qsl(body.decode()))["JWT"]
            self.deep_links.append(jwt.decode(token, jwt.PyJWK(key).key, algorithms=["RS256"], audience=ISSUER,
                                              issuer=CLIENT))  # fmt: skip
            page = b'<!doctype html><html lang="en"><title>LMS</title><link rel="icon" href="data:,">'
            page += b'<h1 id="added">Added</h1></html>'
            handler.send_response(200)
            handler.send_header("Content-Type", "text/html; charset=utf-8")
            handler.send_header("Content-Length", str(len(page)))
            handler.end_headers()
            handler.wfile.write(page)
            return None
        if parts.path == "/token" and method == "POST":
            return self._token(handler, dict(urllib.parse.parse_qsl(body.decode())))
        scope = self.tokens.get(handler.headers.get("Authorization", "").removeprefix("Bearer "))
        if scope is None:
            return _send(handler, 401, {"error": "invalid_token"})
        if parts.path == "/courses/7/members" and method == "GET":
            if "contextmembership" not in scope:
                return _send(handler, 403, {"error": "scope"})
            offset = int(dict(urllib.parse.parse_qsl(parts.query)).get("from", "0"))
            page = self.members[offset : offset + PAGE]
            more = {"Link": f'<{self.base}/courses/7/members?from={offset + PAGE}>; rel="next"'} if (
                offset + PAGE < len(self.members)) else {}  # fmt: skip
            return _send(handler, 200, {"id": "m", "context": {"id": COURSE}, "members": page}, more)
        if parts.path == "/courses/7/lineitems":
            if "lineitem" not in scope:
                return _send(handler, 403, {"error": "scope"})
            if method == "GET":
                if self.broken_items:  # a PHP notice, or a proxy's page, where JSON was asked for
                    return _send(handler, 200, None, {}, b"<html>Notice: Undefined index</html>")
                with self.lock:
                    items = list(self.items.values())
                return _send(handler, 200, items)  # the filter left to the tool (some LMSes ignore it)
            made = json.loads(body)
            with self.lock:
                number = len(self.items) + 1
                self.items[number] = {**made, "id": f"{self.base}/courses/7/lineitems/{number}"}
                return _send(handler, 201, self.items[number])
        if parts.path.startswith("/courses/7/lineitems/") and parts.path.endswith("/scores") and method == "POST":
            if "score" not in scope:
                return _send(handler, 403, {"error": "scope"})
            number = int(parts.path.split("/")[-2])
            if handler.headers.get("Content-Type") != "application/vnd.ims.lis.v1.score+json":
                return _send(handler, 415, {"error": "type"})
            score = json.loads(body)
            if self.moved:
                return _send(handler, 302, None, {"Location": f"{self.base}/moved"})
            if self.members and score["userId"] not in {m["user_id"] for m in self.members}:
                return _send(handler, 422, {"error": "no such user in the course"})
            with self.lock:
                if number not in self.items:
                    return _send(handler, 404, {"error": "no such line item"})
                self.scores.setdefault(number, []).append(score)
            return _send(handler, 204, None)
        return _send(handler, 404, {"error": "no such address"})

    def _token(self, handler: http.server.BaseHTTPRequestHandler, form: dict[str, str]) -> None:
        """OAuth 2's client credentials, the client's assertion checked against the tool's published keys."""
        if form.get("grant_type") != "client_credentials" or not self.tool_jwks_url:
            return _send(handler, 400, {"error": "unsupported_grant_type"})
        with urllib.request.urlopen(self.tool_jwks_url, timeout=10) as answer:  # noqa: S310 - loopback
            keys = json.load(answer)["keys"]
        try:
            kid = jwt.get_unverified_header(form["client_assertion"])["kid"]
            (key,) = [k for k in keys if k["kid"] == kid]
            claims = jwt.decode(form["client_assertion"], jwt.PyJWK(key).key, algorithms=["RS256"],
                                audience=f"{self.base}/token", issuer=CLIENT)  # fmt: skip
            assert claims["sub"] == CLIENT and claims["jti"]
        except (KeyError, ValueError, AssertionError, jwt.PyJWTError):
            return _send(handler, 401, {"error": "invalid_client"})
        token = secrets.token_urlsafe(16)
        self.tokens[token] = form.get("scope", "")
        return _send(handler, 200, {"access_token": token, "token_type": "Bearer", "expires_in": 3600})


def _send(handler: http.server.BaseHTTPRequestHandler, status: int, data, headers: dict | None = None,
          raw: bytes = b"") -> None:  # fmt: skip
    body = raw if data is None else json.dumps(data).encode()
    handler.send_response(status)
    handler.send_header("Content-Type", "application/json")
    handler.send_header("Content-Length", str(len(body)))
    for name, value in (headers or {}).items():
        handler.send_header(name, value)
    handler.end_headers()
    handler.wfile.write(body)
