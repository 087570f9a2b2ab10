"""The class inside a school's LMS: an LTI 1.3 tool's sign-in (OIDC login, launch, JWKS).

An LMS (Moodle, Canvas, Brightspace, Schoology) signs a person in to the class by LTI 1.3: the
LMS sends the browser to the tool's *login* address; the tool sends it back to the LMS's
authorisation address with a ``state`` (kept by the tool, and in a cookie of the browser's) and a
``nonce``; the LMS posts the browser to the tool's *launch* address with an ``id_token``, a JSON
Web Token signed with the LMS's key (RS256). The tool checks it whole before it trusts a word of
it: the signature against the LMS's published keys, the issuer, the audience (the client id the
LMS gave the tool), the deployment, the times, the nonce (used once), the state (the one this
browser was given), the message's type and LTI's version. A learner is then signed in to the
student's page, an instructor to the teacher's desk; a launch whose token fails any check is
refused (401) with one line saying which.

What the tool is told of its LMS (:class:`Platform`) is kept in the class's folder as
``lti/platform.json``, written by ``autonomy class lti-config``; its own key pair is
``lti/tool-key.pem``, readable by the teacher alone, and its public half is served as the JWKS.

PyJWT checks the signature and the claims; the times are checked here against this machine's wall
clock (the clock module's), with :data:`LEEWAY_S` for an LMS whose clock is a little off.

A login keeps nothing: its state is signed by the tool (a random part, when it lapses, and a MAC),
so that no flood of logins can push out a real one's; its nonce is the MAC of the state's random
part, and is remembered as used once a launch with it was checked whole. A launch's state is
checked before the LMS's keys are asked for, so that a junk launch costs no fetch. A class is one
course's: an instructor's first launch ties it to that course (or ``lti-config --course-id``
does), and from then on a launch from any other course is refused.
"""

from __future__ import annotations

import base64
import collections
import dataclasses
import hashlib
import hmac
import http.client
import json
import math
import os
import secrets
import urllib.parse
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import Any

from autonomy.clock import wall_time_s
from autonomy.errors import AutonomyError
from autonomy.views.lines import printable

#: The folder of a class's folder that holds its LTI settings and its key.
LTI_FOLDER = "lti"
PLATFORM_FILE = "platform.json"
KEY_FILE = "tool-key.pem"
#: How far an LMS's clock may be off this machine's, seconds (an id_token's exp, iat, nbf).
LEEWAY_S = 60.0
#: How long a login's state waits for its launch, seconds.
STATE_S = 600.0
#: How long a nonce is remembered as used, seconds (longer than any id_token a launch takes lives).
NONCE_S = 3600.0
#: How long the LMS's published keys are kept before they are asked for again, seconds.
JWKS_KEPT_S = 600.0
#: Longest an LMS's keys take to be fetched, seconds; most bytes they may be.
JWKS_TIMEOUT_S = 5.0
JWKS_MOST_BYTES = 256 * 1024
#: How long after the LMS's keys could not be had they are not asked for again, seconds (launches refused at once).
JWKS_RETRY_S = 10.0
#: The name of the cookie that ties a login's state to the browser it was given to (``__Host-``: this host's alone,
#: sent over HTTPS alone, for the whole site).
STATE_COOKIE = "__Host-autonomy-lti-state"

_LTI = "https://purl.imsglobal.org/spec/lti/claim/"
_DL = "https://purl.imsglobal.org/spec/lti-dl/claim/"
#: How long a deep link's answer may wait for the teacher's press, seconds.
DEEP_LINK_S = 600.0
_NRPS = "https://purl.imsglobal.org/spec/lti-nrps/claim/namesroleservice"
_AGS = "https://purl.imsglobal.org/spec/lti-ags/claim/endpoint"
#: The roles that open the teacher's desk: the course's instructors and content developers (full names, and the
#: short ones LTI 1.3 still allows for a course's roles), and the LMS's administrators. An institution's role
#: (``institution/person#Instructor``: a teacher somewhere in the school) is not this course's: a learner here.
INSTRUCTOR_ROLES = (
    "http://purl.imsglobal.org/vocab/lis/v2/membership#Instructor",
    "http://purl.imsglobal.org/vocab/lis/v2/membership#ContentDeveloper",
    "http://purl.imsglobal.org/vocab/lis/v2/institution/person#Administrator",
    "http://purl.imsglobal.org/vocab/lis/v2/system/person#Administrator",
    "Instructor",
    "ContentDeveloper",
)


class LtiError(AutonomyError):
    """LTI settings that cannot be used (a platform file with problems, a key that cannot be made)."""


class LaunchRefused(Exception):
    """A login or launch the tool does not take; its message is one line saying why."""


@dataclasses.dataclass(frozen=True)
class Platform:
    """What the tool knows of the LMS that launches it.

    Attributes:
        issuer: The LMS's ``iss``, e.g. ``https://moodle.school.example``.
        client_id: The client id the LMS gave this tool (each id_token's audience).
        auth_url: Where the LMS takes the login's answer (its OIDC authorisation address).
        token_url: Where the LMS gives access tokens (for its roster and gradebook).
        jwks_url: Where the LMS publishes its public keys.
        deployment_ids: The deployments of this tool that may launch it.
        jwks: The LMS's keys, given here rather than fetched (a JWKS document), or None.
        public_url: The address the LMS knows the tool by (``https://class.school.example``); empty: the requests'.
        course_id: The LMS's id of the class's course (its ``context``); empty: the first instructor's launch says.
        frame_origins: The origins whose pages may frame the class's (the LMS's pages', where not its issuer's:
            Canvas's cloud issuer is ``https://canvas.instructure.com``, its pages the school's own host).
    """

    issuer: str
    client_id: str
    auth_url: str
    token_url: str
    jwks_url: str
    deployment_ids: tuple[str, ...]
    jwks: dict[str, Any] | None = None
    public_url: str = ""
    course_id: str = ""
    frame_origins: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class Launch:
    """Who a checked launch signs in.

    Attributes:
        subject: The LMS's id of the person (``sub``).
        name: Their name as the LMS gives it (empty if it gives none).
        roster_id: Their institution's id (``lis.person_sourcedid``), empty if none.
        instructor: Whether they teach the course (an instructor's role), else a learner.
        resource_link: The LMS's id of the link that was followed.
        course_id: The LMS's id of the course it was followed in (its ``context``).
        course_title: The course's title, as the LMS gives it (empty if none).
        memberships_url: Where the LMS lists the course's people (its Names and Roles service); empty: none.
        lineitems_url: Where the LMS keeps the course's line items (its Assignment and Grade service); empty: none.
        lineitem_url: The link's own line item, if the LMS made one for it; empty: none.
        deployment: The deployment it came by.
        deep_link: Where a teacher adding the class to the course is sent back to, and what the LMS asked to be
            given back (its ``data``), for a deep-linking request (the LMS's "add external tool"); None: a launch.
    """

    subject: str
    name: str
    roster_id: str
    instructor: bool
    resource_link: str
    course_id: str = ""
    course_title: str = ""
    memberships_url: str = ""
    lineitems_url: str = ""
    lineitem_url: str = ""
    deployment: str = ""
    deep_link: tuple[str, str] | None = None


def lti_folder(class_folder: Path) -> Path:
    return Path(class_folder) / LTI_FOLDER


def read_platform(class_folder: Path) -> Platform | None:
    """The class's LMS, as ``class lti-config`` wrote it; None when it has none.

    Raises:
        LtiError: the file is there but cannot be read, or lacks what a launch needs.
    """
    path = lti_folder(class_folder) / PLATFORM_FILE
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise LtiError(f"{path}: cannot read the LMS's settings: {err}") from err
    if not isinstance(data, dict):
        raise LtiError(f"{path}: the LMS's settings are a JSON object; make them anew with autonomy class lti-config")
    missing = [key for key in ("issuer", "client_id", "auth_url", "deployment_ids") if not data.get(key)]
    if not data.get("jwks_url") and not data.get("jwks"):
        missing.append("jwks_url")
    if missing:
        raise LtiError(f"{path}: the LMS's {', '.join(missing)} missing: give them to autonomy class lti-config")
    ids = data["deployment_ids"]
    if not isinstance(ids, list) or not all(isinstance(i, str) and i for i in ids):
        raise LtiError(f"{path}: deployment_ids is a list of the LMS's deployment ids")
    texts = ("issuer", "client_id", "auth_url", "token_url", "jwks_url", "public_url", "course_id")
    odd = [key for key in texts if not isinstance(data.get(key, ""), str)]
    jwks = data.get("jwks")
    if jwks is not None and not (isinstance(jwks, dict) and isinstance(jwks.get("keys"), list)):
        odd.append("jwks")
    frames = data.get("frame_origins", [])
    if not isinstance(frames, list) or not all(isinstance(f, str) and _origin(f) == f for f in frames):
        odd.append("frame_origins")
    if odd:
        raise LtiError(f"{path}: the LMS's {', '.join(odd)} not as lti-config writes them; make them anew with it")
    return Platform(
        data["issuer"],
        data["client_id"],
        data["auth_url"],
        data.get("token_url", ""),
        data.get("jwks_url", ""),
        tuple(ids),
        jwks,
        data.get("public_url", ""),
        data.get("course_id", ""),
        tuple(frames),
    )


def write_platform(class_folder: Path, platform: Platform) -> Path:
    """Keeps the class's LMS settings (the teacher's alone); the file's path."""
    folder = lti_folder(class_folder)
    folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    path = folder / PLATFORM_FILE
    data = dataclasses.asdict(platform)
    data["deployment_ids"] = list(platform.deployment_ids)
    data["frame_origins"] = list(platform.frame_origins)
    if data["jwks"] is None:
        del data["jwks"]
    path.write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    path.chmod(0o600)
    return path


def _origin(url: str) -> str:
    """A URL's origin (``https://host[:port]``); empty for what is not an http(s) URL."""
    parts = urllib.parse.urlsplit(url)
    return f"{parts.scheme}://{parts.netloc}" if parts.scheme in ("http", "https") and parts.netloc else ""


def frame_origins(platform: Platform, *urls: str) -> list[str]:
    """The origins that may frame the class's pages: the issuer's, those given, and those of the LMS's ``urls``."""
    found = [_origin(platform.issuer), *platform.frame_origins, *(_origin(url) for url in urls)]
    return [origin for k, origin in enumerate(found) if origin and origin not in found[:k] and " " not in origin]


def _b64(number: int) -> str:
    raw = number.to_bytes((number.bit_length() + 7) // 8, "big")
    return base64.urlsafe_b64encode(raw).rstrip(b"=").decode("ascii")


class ToolKey:
    """The tool's own RSA key pair, kept in the class's folder (made at first use, readable by its owner alone).

    Raises:
        LtiError: the key cannot be read or made.
    """

    def __init__(self, class_folder: Path) -> None:
        from cryptography.hazmat.primitives import serialization
        from cryptography.hazmat.primitives.asymmetric import rsa

        folder = lti_folder(class_folder)
        path = folder / KEY_FILE
        try:
            folder.mkdir(mode=0o700, parents=True, exist_ok=True)
            if path.is_file():
                key = serialization.load_pem_private_key(path.read_bytes(), password=None)
            else:
                key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
                pem = key.private_bytes(
                    serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
                )
                descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
                with os.fdopen(descriptor, "wb") as out:
                    out.write(pem)
        except (OSError, ValueError) as err:
            raise LtiError(f"{path}: cannot keep the tool's key there: {err}") from err
        if not isinstance(key, rsa.RSAPrivateKey):
            raise LtiError(f"{path}: the tool's key is not an RSA key; remove it and a new one is made")
        self.path = path
        self.private = key
        numbers = key.public_key().public_numbers()
        self.kid = hashlib.sha256(f"{numbers.n}:{numbers.e}".encode()).hexdigest()[:16]
        self._public = {"kty": "RSA", "alg": "RS256", "use": "sig", "kid": self.kid, "n": _b64(numbers.n),
                        "e": _b64(numbers.e)}  # fmt: skip

    def jwks(self) -> dict[str, Any]:
        """The tool's public key as a JWKS document (what the LMS checks the tool's signatures with)."""
        return {"keys": [dict(self._public)]}


def tool_urls(base_url: str) -> dict[str, str]:
    """The tool's addresses an LMS's admin pastes in, under ``base_url`` (``https://class.school.example``)."""
    base = base_url.rstrip("/")
    return {
        "tool_url": f"{base}/lti/launch",
        "login_url": f"{base}/lti/login",
        "redirect_uri": f"{base}/lti/launch",
        "jwks_url": f"{base}/lti/jwks",
    }


def canvas_config(base_url: str, title: str) -> dict[str, Any]:
    """Canvas's "paste JSON" developer key configuration of the tool."""
    urls = tool_urls(base_url)
    host = urllib.parse.urlsplit(base_url).hostname or ""
    return {
        "title": title,
        "description": "Behaviour-tree missions for the class's robot: write, run, hand in.",
        "oidc_initiation_url": urls["login_url"],
        "target_link_uri": urls["tool_url"],
        "public_jwk_url": urls["jwks_url"],
        "scopes": [
            "https://purl.imsglobal.org/spec/lti-ags/scope/lineitem",
            "https://purl.imsglobal.org/spec/lti-ags/scope/score",
            "https://purl.imsglobal.org/spec/lti-nrps/scope/contextmembership.readonly",
        ],
        "extensions": [
            {
                "domain": host,
                "platform": "canvas.instructure.com",
                "privacy_level": "public",
                "settings": {
                    "placements": [  # the teacher adds the class by deep linking, as a module's item or an assignment
                        {
                            "placement": placement,
                            "message_type": "LtiDeepLinkingRequest",
                            "target_link_uri": urls["tool_url"],
                        }
                        for placement in ("link_selection", "assignment_selection")
                    ]
                },  # fmt: skip
            }
        ],
        "custom_fields": {},
    }


def _fetch_jwks(url: str) -> dict[str, Any]:
    """The LMS's published keys (blocking: called off the server's loop)."""
    request = urllib.request.Request(url, headers={"Accept": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=JWKS_TIMEOUT_S) as answer:  # noqa: S310 - the LMS's, as set
            body = answer.read(JWKS_MOST_BYTES + 1)
    except http.client.HTTPException as err:  # an answer cut short, or not HTTP
        raise ValueError(f"a broken answer ({type(err).__name__})") from err
    if len(body) > JWKS_MOST_BYTES:
        raise ValueError(f"more than {JWKS_MOST_BYTES:,} bytes")
    data = json.loads(body)
    if not isinstance(data, dict) or not isinstance(data.get("keys"), list):
        raise ValueError("not a JWKS document (an object with its keys)")
    return data


def state_cookie(state: str) -> str:
    """The name of the cookie that holds ``state`` (one each: two tabs' logins do not take each other's place)."""
    return f"{STATE_COOKIE}-{hashlib.sha256(state.encode()).hexdigest()[:16]}"


class LtiTool:
    """The tool's side of LTI 1.3's sign-in: logins answered, launches checked; thread-safe enough for one loop.

    Args:
        platform: The LMS that launches it.
        key: The tool's own key pair.
        fetch_jwks: Fetches the LMS's keys from an address (blocking; the caller runs it off its loop).
    """

    def __init__(
        self, platform: Platform, key: ToolKey, fetch_jwks: Callable[[str], dict[str, Any]] = _fetch_jwks
    ) -> None:
        self.platform = platform
        self.key = key
        self._fetch = fetch_jwks
        #: What the states are signed with (this run's alone: a state of a run before is not taken).
        self._secret = secrets.token_bytes(32)
        #: Each nonce a launch used, and when it may be forgotten.
        self._used: collections.OrderedDict[str, float] = collections.OrderedDict()
        self._jwks: tuple[dict[str, Any], float] | None = None
        #: When the LMS's keys last could not be had, and why.
        self._unfetched: tuple[float, str] | None = None

    def _mac(self, text: str) -> str:
        return hmac.new(self._secret, text.encode(), hashlib.sha256).hexdigest()[:32]

    def login(self, given: dict[str, str], redirect_uri: str) -> tuple[str, str]:
        """The answer to an LMS's login initiation: where to send the browser back to, and the state to keep.

        Raises:
            LaunchRefused: the login is not from this class's LMS, or lacks what LTI says it must hold.
        """
        if given.get("iss") != self.platform.issuer:
            raise LaunchRefused(f"a login from {_said(given.get('iss'))}, not from this class's LMS")
        if given.get("client_id") not in (None, "", self.platform.client_id):
            raise LaunchRefused("a login for another tool's client id")
        if not given.get("login_hint"):
            raise LaunchRefused("a login without its login_hint: it did not come from an LMS's launch")
        raw = f"{secrets.token_urlsafe(18)}.{int(wall_time_s() + STATE_S)}"
        state = f"{raw}.{self._mac('state ' + raw)}"
        query = {
            "scope": "openid",
            "response_type": "id_token",
            "response_mode": "form_post",
            "prompt": "none",
            "client_id": self.platform.client_id,
            "redirect_uri": redirect_uri,
            "login_hint": given["login_hint"],
            "state": state,
            "nonce": self._mac("nonce " + raw),
        }
        if given.get("lti_message_hint"):
            query["lti_message_hint"] = given["lti_message_hint"]
        return f"{self.platform.auth_url}?{urllib.parse.urlencode(query)}", state

    def claim(self, state: str, cookie_state: str) -> str:
        """A launch's state checked (this tool's, not lapsed, this browser's): the nonce its token must hold.

        Cheap, and asks nobody: a launch is checked this far before the LMS's keys are asked for.

        Raises:
            LaunchRefused: the state is not one this tool gave, has lapsed, or is not the browser's.
        """
        raw, _, mac = state.rpartition(".")
        _, _, until = raw.partition(".")
        if not raw or not secrets.compare_digest(mac.encode(), self._mac("state " + raw).encode()):
            raise LaunchRefused("a launch whose state this tool did not give: start it again from the LMS")
        if not until.isdigit() or int(until) <= wall_time_s():
            raise LaunchRefused("a launch whose login lapsed (10 minutes): start it again from the LMS")
        if not cookie_state or not secrets.compare_digest(cookie_state.encode(), state.encode()):
            raise LaunchRefused("a launch whose state is not this browser's: start it again from the LMS")
        nonce = self._mac("nonce " + raw)
        if nonce in self._used:
            raise LaunchRefused("a launch whose state was used already: start it again from the LMS")
        return nonce

    def keys(self, again: bool = False) -> dict[str, Any]:
        """The LMS's keys: given, kept from a fetch less than :data:`JWKS_KEPT_S` old, or fetched now (blocking).

        Args:
            again: Fetch them anew, kept or not (a token named a key the kept ones lack: the LMS's new key).

        Raises:
            LaunchRefused: they cannot be fetched (nor are they asked for again within :data:`JWKS_RETRY_S`).
        """
        if self.platform.jwks is not None:
            return self.platform.jwks
        now_s = wall_time_s()
        if self._jwks is not None and self._jwks[1] > now_s and not again:
            return self._jwks[0]
        if self._unfetched is not None and self._unfetched[0] + JWKS_RETRY_S > now_s:
            raise LaunchRefused(self._unfetched[1])
        try:
            jwks = self._fetch(self.platform.jwks_url)
        except (OSError, ValueError) as err:
            self._unfetched = (now_s, f"the LMS's keys could not be had from {self.platform.jwks_url}: {err}")
            raise LaunchRefused(self._unfetched[1]) from err
        self._jwks, self._unfetched = (jwks, now_s + JWKS_KEPT_S), None
        return jwks

    def needs_fetch(self, again: bool = False) -> bool:
        """Whether :meth:`keys` would fetch (the caller then runs it off its loop)."""
        if self.platform.jwks is not None:
            return False
        now_s = wall_time_s()
        if self._unfetched is not None and self._unfetched[0] + JWKS_RETRY_S > now_s:
            return False  # refused at once
        return again or self._jwks is None or self._jwks[1] <= now_s

    def fetched_at_s(self) -> float:
        """When the kept keys were fetched (0: none kept), so that a key the LMS added is fetched once a while."""
        return 0.0 if self._jwks is None else self._jwks[1] - JWKS_KEPT_S

    def check(self, id_token: str, nonce: str, jwks: dict[str, Any], course: str = "") -> Launch:
        """Checks a launch's token whole; who it signs in.

        Args:
            id_token: The form's ``id_token``.
            nonce: What its state says its nonce is (:meth:`claim`).
            jwks: The LMS's keys (:meth:`keys`).
            course: The LMS's id of the class's course; empty: not yet tied to one (an instructor's launch ties it).

        Raises:
            LaunchRefused: any check fails; its message says which, in one line.
            UnknownKey: the token is signed with a key the LMS does not publish (in ``jwks``).
        """
        import jwt

        now_s = wall_time_s()
        self._forget(now_s)
        try:
            header = jwt.get_unverified_header(id_token)
        except jwt.PyJWTError as err:
            raise LaunchRefused(f"the id_token is not a signed token: {err}") from err
        if header.get("alg") != "RS256":
            raise LaunchRefused(f"the id_token is signed with {_said(header.get('alg'))}; LTI 1.3 signs with RS256")
        key = _key_for(jwks, header.get("kid"))
        try:
            claims = jwt.decode(
                id_token,
                key=key,
                algorithms=["RS256"],
                audience=self.platform.client_id,
                issuer=self.platform.issuer,
                options={
                    "require": ["iss", "aud", "exp", "iat", "nonce", "sub"],
                    "verify_exp": False,
                    "verify_iat": False,
                    "verify_nbf": False,
                },  # fmt: skip - the times are checked below
            )
        except jwt.InvalidSignatureError as err:
            raise LaunchRefused("the id_token's signature is not the LMS's") from err
        except jwt.InvalidAudienceError as err:
            raise LaunchRefused("the id_token is for another tool (its audience is not this tool's client id)") from err
        except jwt.InvalidIssuerError as err:
            raise LaunchRefused("the id_token is from another LMS (its issuer is not this class's)") from err
        except jwt.PyJWTError as err:
            raise LaunchRefused(f"the id_token does not hold: {err}") from err
        _check_times(claims, now_s)
        audience = claims["aud"]
        several = isinstance(audience, list) and len(audience) > 1
        if (several or "azp" in claims) and claims.get("azp") != self.platform.client_id:
            raise LaunchRefused("the id_token's azp (the party it was given to) is not this tool's client id")
        if not isinstance(claims["nonce"], str) or not secrets.compare_digest(claims["nonce"], nonce):
            raise LaunchRefused("the id_token's nonce is not the one its login was given")
        if claims["nonce"] in self._used:
            raise LaunchRefused("the id_token was used already: start it again from the LMS")
        deployment = claims.get(_LTI + "deployment_id")
        if deployment not in self.platform.deployment_ids:
            raise LaunchRefused(f"the launch is from deployment {_said(deployment)}, not one of this class's")
        kind = claims.get(_LTI + "message_type")
        if kind not in ("LtiResourceLinkRequest", "LtiDeepLinkingRequest"):
            raise LaunchRefused(f"a {_said(kind)} message; a launch is an LtiResourceLinkRequest (or deep linking)")
        if claims.get(_LTI + "version") != "1.3.0":
            raise LaunchRefused(f"LTI version {_said(claims.get(_LTI + 'version'))}; this tool speaks 1.3.0")
        link = claims.get(_LTI + "resource_link") if kind == "LtiResourceLinkRequest" else {"id": "-"}
        if not isinstance(link, dict) or not isinstance(link.get("id"), str) or not link["id"]:
            raise LaunchRefused("the launch names no resource link")
        roles = claims.get(_LTI + "roles")
        if not isinstance(roles, list):
            raise LaunchRefused("the launch gives no roles")
        if not isinstance(claims["sub"], str) or not claims["sub"].strip():
            raise LaunchRefused("the id_token names nobody (its sub is empty)")
        if len(claims["sub"]) > 255:
            raise LaunchRefused("the id_token's sub is longer than OpenID Connect's 255 characters")
        instructor = any(role in INSTRUCTOR_ROLES for role in roles)
        deep_link = _deep_link(claims) if kind == "LtiDeepLinkingRequest" else None
        if deep_link is not None and not instructor:
            raise LaunchRefused("only a teacher of the course adds the class to it (deep linking)")
        context = claims.get(_LTI + "context")
        course_id = context.get("id") if isinstance(context, dict) else None
        if not isinstance(course_id, str) or not course_id:
            raise LaunchRefused("the launch names no course (its context): launch it from a course's link")
        bound = self.platform.course_id or course
        if bound and course_id != bound:
            raise LaunchRefused(f"a launch from course {_said(course_id)}, not this class's ({_said(bound)})")
        if not bound and not instructor:
            raise LaunchRefused("the class is not yet tied to a course: its teacher opens the link first")
        self._used[claims["nonce"]] = now_s + NONCE_S  # checked whole: used
        person = claims.get(_LTI + "lis")
        sourced = person.get("person_sourcedid", "") if isinstance(person, dict) else ""
        name = claims.get("name") or " ".join(str(claims.get(k, "")) for k in ("given_name", "family_name")).strip()
        names = claims.get(_NRPS)
        grades = claims.get(_AGS)
        names = names if isinstance(names, dict) else {}
        grades = grades if isinstance(grades, dict) else {}
        return Launch(
            claims["sub"],
            _text(name),
            _text(sourced),
            instructor,
            link["id"],
            course_id,
            _text(context.get("title") or context.get("label")),
            _text(names.get("context_memberships_url")),
            _text(grades.get("lineitems")),
            _text(grades.get("lineitem")),
            deployment,
            deep_link,
        )

    def deep_link_answer(self, launch: Launch, item: dict[str, Any] | None) -> str:
        """The signed answer to a deep-linking request: the class's exercise as the link to add (an id_token's JWT).

        Args:
            launch: The deep-linking request (:meth:`check`).
            item: The content item: an ``ltiResourceLink`` (its title, text, url and line item); None: nothing.
        """
        import jwt

        if launch.deep_link is None:
            raise ValueError("not a deep-linking request")
        now_s = int(wall_time_s())
        claims: dict[str, Any] = {
            "iss": self.platform.client_id,
            "aud": self.platform.issuer,
            "iat": now_s,
            "exp": now_s + int(DEEP_LINK_S),
            "nonce": secrets.token_urlsafe(18),
            _LTI + "deployment_id": launch.deployment,
            _LTI + "message_type": "LtiDeepLinkingResponse",
            _LTI + "version": "1.3.0",
            _DL + "content_items": [item] if item is not None else [],
        }
        if launch.deep_link[1]:
            claims[_DL + "data"] = launch.deep_link[1]
        return jwt.encode(claims, self.key.private, algorithm="RS256", headers={"kid": self.key.kid})

    def _forget(self, now_s: float) -> None:
        """Lets go of nonces past their time."""
        while self._used and next(iter(self._used.values())) <= now_s:
            self._used.popitem(last=False)


class UnknownKey(LaunchRefused):
    """A token signed with a key the LMS's keys (as kept) do not hold: perhaps a new one, fetched once again."""


def _deep_link(claims: dict[str, Any]) -> tuple[str, str]:
    """A deep-linking request's return address and data, checked: it takes a link to the tool."""
    settings = claims.get(_DL + "deep_linking_settings")
    if not isinstance(settings, dict):
        raise LaunchRefused("a deep-linking request without its settings")
    back = settings.get("deep_link_return_url")
    if not isinstance(back, str) or urllib.parse.urlsplit(back).scheme not in ("https", "http"):
        raise LaunchRefused("a deep-linking request with no address to return to")
    accepted = settings.get("accept_types")
    if not isinstance(accepted, list) or "ltiResourceLink" not in accepted:
        raise LaunchRefused("the LMS takes no link to a tool here (accept_types lacks ltiResourceLink)")
    return back, _text(settings.get("data"))


def _text(value: object) -> str:
    """A claim's text, or empty (a claim that is not text is none)."""
    return value if isinstance(value, str) else ""


def _said(value: object) -> str:
    """A value a refusal says back: printable, short."""
    text = printable(repr(value) if not isinstance(value, str) else f"'{value}'")
    return text[:60] + ("..." if len(text) > 60 else "")


def _key_for(jwks: dict[str, Any], kid: object) -> Any:
    """The LMS's public key the token names (by ``kid``; the only one, if it names none)."""
    import jwt

    listed = jwks.get("keys") if isinstance(jwks, dict) else None
    # an RSA public key for signatures by RS256 (a key for encryption, or for another algorithm, is not one)
    keys = [
        k for k in (listed if isinstance(listed, list) else [])
        if isinstance(k, dict) and k.get("kty") == "RSA" and "d" not in k and k.get("use", "sig") == "sig"
        and k.get("alg", "RS256") == "RS256"
    ]  # fmt: skip
    chosen = [k for k in keys if k.get("kid") == kid] if kid is not None else keys[:1] if len(keys) == 1 else []
    if not chosen:
        raise UnknownKey(f"the id_token is signed with key {_said(kid)}, which the LMS does not publish")
    try:
        return jwt.PyJWK(chosen[0], algorithm="RS256").key
    except jwt.PyJWTError as err:
        raise LaunchRefused(f"the LMS's key {_said(kid)} cannot be read: {err}") from err


def _check_times(claims: dict[str, Any], now_s: float) -> None:
    """The id_token's times against this machine's clock, within :data:`LEEWAY_S`."""
    for name in ("exp", "iat", "nbf"):
        value = claims.get(name)
        if name == "nbf" and value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise LaunchRefused(f"the id_token's {name} is not a time")
    if claims["exp"] + LEEWAY_S <= now_s:
        raise LaunchRefused("the id_token has expired: start it again from the LMS")
    if claims["iat"] - LEEWAY_S > now_s or claims.get("nbf", now_s) - LEEWAY_S > now_s:
        raise LaunchRefused("the id_token is from the future: is the LMS's clock or this machine's wrong?")


__all__ = [
    "Launch",
    "LaunchRefused",
    "LtiError",
    "LtiTool",
    "Platform",
    "ToolKey",
    "UnknownKey",
    "canvas_config",
    "frame_origins",
    "state_cookie",
    "read_platform",
    "tool_urls",
    "write_platform",
]
