"""What a fixed time stamp becomes in each file format, so that a kit written twice is the same bytes.

The time stamp itself is checked and normalised in one place, :func:`fabpat.exchange.part.check_timestamp`;
everything here starts from its result. A file format's own clock fields (ZIP member dates, DXF Julian
dates, 3DM revision times) get the stamp's time, and identifiers that writers otherwise draw at random
(DXF GUIDs, 3DM object and layer ids) are name-based UUIDs (RFC 4122 version 5) of the stamp and of what
they identify, so the same input gives the same identifiers in every run and distinct things get distinct ones.
"""

from __future__ import annotations

import uuid
from datetime import UTC, datetime

from fabpat.exchange.part import check_timestamp

#: the namespace of fabpat's name-based UUIDs: itself the name-based UUID of the package's name (a constant;
#: changing it changes every identifier of every reproducible file)
NAMESPACE = uuid.uuid5(uuid.NAMESPACE_OID, "fabpat")
#: ZIP (MS-DOS) dates run from 1980-01-01 00:00:00 to 2107-12-31 23:59:58
ZIP_FIRST = (1980, 1, 1, 0, 0, 0)
ZIP_LAST = (2107, 12, 31, 23, 59, 58)


def stamp_time(timestamp: str) -> datetime:
    """The instant of ``timestamp`` (any spelling :func:`~fabpat.exchange.part.check_timestamp` accepts) as a
    :class:`~datetime.datetime`, aware (its zone) when a zone is given, naive otherwise; whole seconds.
    Raises :class:`~fabpat.errors.ExportError` for a time stamp that is not ISO 8601."""
    text = check_timestamp(timestamp, "timestamp")
    assert text is not None  # not None for a str
    return datetime.fromisoformat(text.replace("Z", "+00:00"))


def utc_time(timestamp: str) -> datetime:
    """The instant of ``timestamp`` in UTC, naive; a time stamp without a zone is taken as UTC.
    Raises :class:`~fabpat.errors.ExportError` as :func:`stamp_time`."""
    t = stamp_time(timestamp)
    return t if t.tzinfo is None else t.astimezone(UTC).replace(tzinfo=None)


def zip_date_time(timestamp: str) -> tuple[int, int, int, int, int, int]:
    """A ZIP member's ``date_time`` (year, month, day, hour, minute, second) for ``timestamp``, in UTC.

    ZIP stores MS-DOS dates: from 1980-01-01 to 2107-12-31, in steps of 2 s. An earlier stamp gives
    1980-01-01 00:00:00 and a later one 2107-12-31 23:59:58 (clamped, not refused: the ZIP date only
    tells a reader when the member was made; the stamp itself is in no 3MF field). Raises
    :class:`~fabpat.errors.ExportError` as :func:`stamp_time`."""
    t = utc_time(timestamp)
    fields = (t.year, t.month, t.day, t.hour, t.minute, t.second)
    return min(max(fields, ZIP_FIRST), ZIP_LAST)


def stamp_uuid(timestamp: str, *names: str) -> uuid.UUID:
    """The name-based UUID (version 5, :data:`NAMESPACE`) of ``names`` written at ``timestamp``: the same for the
    same arguments in every run, different for different ones. Raises :class:`~fabpat.errors.ExportError`
    as :func:`stamp_time`."""
    text = check_timestamp(timestamp, "timestamp")
    return uuid.uuid5(NAMESPACE, "\x1f".join((str(text), *names)))  # unit separator: no name can fake a split
