"""The status table of trioct_status.h as an IntEnum, and the exceptions a failed call raises.

Every failure carries the code of the shared table (the one daemon, library and command
use), its name and the message that says why, so a Python caller sees what `trioct --json`
prints. The class says who decided:

  DaemonError     a status below 100: the daemon's answer (ERR_UNKNOWN_SHAPE, ERR_EFFECT,
                  ERR_NONFINITE, ...), or the library's refusal of a request with the same
                  code before anything was sent (ERR_OVER_CAP, ERR_BAD_REQUEST; .daemon "")
  NoReply         ERR_NO_DAEMON (nothing came back: no daemon holds the world, or none runs
                  on this bus) and ERR_TIMEOUT (part of the answer came, not all)
  TransportError  ERR_TRANSPORT: the LCM bus could not be opened or used
  BadReply        ERR_BAD_REPLY: replies came back and could not be made sense of
"""

import enum

from . import _constants

Status = enum.IntEnum("Status", [(name, code) for code, name, _ in _constants.STATUS])
Status.__doc__ = "The status codes of trioct_status.h, named as there without TRIOCT_."

_TEXT = {code: text for code, _, text in _constants.STATUS}


def status_name(code):
    """The code's name ("ERR_BUSY"), or "UNKNOWN" for one the table lacks (a newer daemon's)."""
    try:
        return Status(code).name
    except ValueError:
        return "UNKNOWN"


def status_text(code):
    """The table's text for the code, or "unknown status"."""
    return _TEXT.get(code, "unknown status")


class Error(Exception):
    """A trioct call that did not succeed.

    .status   the code: a Status member, or a plain int for a code this package lacks
    .name     its name ("ERR_EFFECT")
    .message  why, in words (the daemon's or the library's message, else the table's text)
    .daemon   the daemon that answered, "" when none did
    .world    the world asked about, "" when none
    """

    def __init__(self, status, message="", daemon="", world=""):
        try:
            self.status = Status(status)
        except ValueError:
            self.status = int(status)
        self.name = status_name(status)
        self.message = message or status_text(status)
        self.daemon = daemon
        self.world = world
        super().__init__("%s: %s" % (self.name, self.message))


class DaemonError(Error):
    """A status below 100 from the shared table: the daemon said no, or the library refused
    the request before sending it (then .daemon is "")."""


class NoReply(Error):
    """No answer, or not all of it, within the timeout (ERR_NO_DAEMON, ERR_TIMEOUT)."""


class TransportError(Error):
    """The LCM bus could not be opened or used (ERR_TRANSPORT)."""


class BadReply(Error):
    """Replies came back but could not be decoded (ERR_BAD_REPLY)."""


def error_for(status, message="", daemon="", world=""):
    """The exception of the class the status belongs to."""
    if status in (Status.ERR_NO_DAEMON, Status.ERR_TIMEOUT):
        cls = NoReply
    elif status == Status.ERR_TRANSPORT:
        cls = TransportError
    elif status == Status.ERR_BAD_REPLY:
        cls = BadReply
    elif 0 < status < 100:
        cls = DaemonError
    else:
        cls = Error
    return cls(status, message, daemon, world)
