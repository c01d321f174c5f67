"""How the EiBotBoard firmware reads one command and words its reply (EBB firmware 3.0.3,
``app.X/source/UBW.c``: ``parse_packet``, ``find_command``, ``extract_number``,
``print_command``, ``print_line_ending``, ``CheckForAndPrintErrors``; the command reference
``docs/ebb.html``, "Syntax and conventions" and "Returned Errors").

Facts implemented here:

* A command is its first one or two characters, upper-cased (the second is taken unless it is a
  comma or the end), then comma-separated parameters.
* A parameter is read as up to 10 decimal digits (none read gives 0) after an optional ``-``;
  the value wraps at 32 bits as the firmware's ``unsigned long`` does; a ``-`` on an unsigned
  type, or a value outside the type's range, is ``!6 Err: Invalid parameter value``. A required
  parameter missing is ``!4 Err: Missing parameter(s)``; a character other than a comma where the
  next parameter should start is ``!5 Err: Need comma next, found: 'X'`` (printed at once); what
  is left after the handler's last parameter is ``!7 Err: Extra parameter`` (checked after the
  handler ran, so a queued command is already queued and has already said ``OK``).
* Once an error is set, later parameters are not read and the first error wins; after the
  handler the error is printed followed by ``\\r\\n`` (no ``OK``: the code, not the reference's
  prose, which says legacy mode ends an error with ``OK\\r\\n``).
* Line endings in legacy mode (the default): "OK" ``OK\\r\\n`` (``OK`` left out after ``CU,1,0``),
  "norm" ``\\r\\n``, "rev" ``\\n\\r``. In future syntax mode (``CU,10,1``) every ending is
  ``\\n`` and replies start with the command's name (``print_command``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

CR = "\r"
MAX_DIGITS = 10
WORD = 1 << 32

# Parameter types of extract_number: (lowest, highest) after the sign is applied.
TYPES = {
    "uchar": (0, 255),
    "char": (-128, 127),
    "uint": (0, 65535),
    "int": (-32768, 32767),
    "ulong": (0, WORD - 1),
    "long": (-(1 << 31), (1 << 31) - 1),
    "ascii": (0, 255),
    "upper": (0, 255),
}
UNSIGNED = ("uchar", "uint", "ulong")

OK, MISSING, COMMA_MISSING, OUTSIDE_LIMIT, SKIPPED = "ok", "missing", "comma", "limit", "skipped"
PRINTED = -1  # kERROR_PRINTED_ERROR: the message went out where the error was found
ERROR_TEXT = {
    1: "!1 Err: Invalid step rate",
    2: "!2 Err: TX Buffer overrun",
    3: "!3 Err: RX Buffer overrun",
    4: "!4 Err: Missing parameter(s)",
    6: "!6 Err: Invalid parameter value",
    7: "!7 Err: Extra parameter",
    10: "!10 Err: No checksum found but required",
}


@dataclass
class Line:
    """One command being parsed and its reply.

    Attributes:
        text: The command as received, without its terminator.
        future: Future syntax mode (``CU,10,1``).
        ack: Legacy mode's ``OK`` (``CU,1``).
        name: The command's one or two upper-case characters.
        error: The error code set (0: none, :data:`PRINTED`: already printed).
        out: The reply so far.
    """

    text: str
    future: bool = False
    ack: bool = True
    name: str = ""
    error: int = 0
    out: list[str] = field(default_factory=list)
    pos: int = 0

    def __post_init__(self) -> None:
        self.buf = self.text + CR
        first = self.buf[0].upper()
        self.pos = 1
        if self.buf[1] not in (",", CR, "\n"):
            self.name = first + self.buf[1].upper()
            self.pos = 2
        else:
            self.name = first

    # -- reading ---------------------------------------------------------------------------

    @property
    def at_end(self) -> bool:
        return self.buf[self.pos] == CR

    def number(self, kind: str, required: bool = True) -> tuple[str, int]:
        """Read the next parameter as ``extract_number`` does: (status, value); the value is 0
        unless the status is :data:`OK`."""
        if self.error:
            return SKIPPED, 0
        if self.at_end:
            if required:
                self.set_error(4)
            return MISSING, 0
        if self.buf[self.pos] != ",":
            if required:
                if self.future:
                    self.put(",")
                self.put(f"!5 Err: Need comma next, found: '{self.buf[self.pos]}'")
                self.set_error(PRINTED)
            return COMMA_MISSING, 0
        self.pos += 1
        if self.at_end:
            if required:
                self.set_error(4)
            return MISSING, 0
        if kind in ("ascii", "upper"):
            char = self.buf[self.pos]
            self.pos += 1
            return OK, ord(char.upper() if kind == "upper" else char) & 0xFF
        negative = self.buf[self.pos] == "-"
        if negative:
            if kind in UNSIGNED:
                self.set_error(6)
                return OUTSIDE_LIMIT, 0
            self.pos += 1
        magnitude = 0
        for _ in range(MAX_DIGITS):
            char = self.buf[self.pos]
            if not "0" <= char <= "9":
                break
            magnitude = (magnitude * 10 + ord(char) - 48) % WORD
            self.pos += 1
        low, high = TYPES[kind]
        value = -magnitude if negative else magnitude
        if value < low or value > high:
            self.set_error(6)
            return OUTSIDE_LIMIT, 0
        return OK, value

    def string(self, limit: int) -> str:
        """The rest of the command after a comma, at most ``limit`` characters (``ST``)."""
        if self.at_end or self.buf[self.pos] != ",":
            return ""
        rest = self.buf[self.pos + 1:-1][:limit]
        self.pos = len(self.buf) - 1
        return rest

    # -- writing -----------------------------------------------------------------------------

    def put(self, text: str) -> None:
        self.out.append(text)

    def set_error(self, code: int) -> None:
        """``ErrorSet``: the first error wins."""
        if not self.error:
            self.error = code

    def echo(self, always: bool = False, comma: bool = False) -> None:
        """``print_command``: the command's name (future mode, or always), then a comma."""
        if self.future or always:
            self.put(self.name + ("," if comma else ""))

    def ending(self, kind: str) -> None:
        """``print_line_ending``: kind "ok", "norm" or "rev" (see the module docstring)."""
        if self.future:
            self.put("\n")
            return
        if kind == "ok" and self.ack:
            self.put("OK")
        self.put("\n\r" if kind == "rev" else "\r\n")

    def finish(self) -> str:
        """The extra-parameter check and the error print that follow every handler; the whole
        reply."""
        if not self.error and not self.at_end and self.name != "R":
            self.echo()
            self.set_error(7)
        if self.error:
            if self.future and self.error != PRINTED:
                self.put(",")
            if self.error != PRINTED:
                self.put(ERROR_TEXT[self.error])
            self.ending("norm")
        return "".join(self.out)


def unknown(line: Line) -> None:
    """The reply to a command name the firmware does not know (``!8``, with the characters'
    hexadecimal codes)."""
    if line.future:
        line.put(line.name + ",")
    codes = "".join(f"{ord(c) & 0xFF:02X}" for c in line.name)
    line.put(f"!8 Err: Unknown command '{line.name}:{codes}'")
    line.set_error(PRINTED)


def checksum(text: str) -> int:
    """The 8-bit two's-complement checksum of ``text`` (``CU,54,1``: 0x100 minus the byte sum,
    modulo 256)."""
    return (-sum(text.encode("latin-1"))) % 256


def strip_checksum(text: str, future: bool = False) -> tuple[str, str]:
    """With checksums required (``CU,54,1``): (the command without its checksum, "") when the
    last comma within the last 5 characters is followed by the right checksum, else ("", the
    firmware's ``!9``/``!10`` reply; the command does not run)."""
    comma = text.rfind(",", max(1, len(text) - 5))
    name = Line(text).name
    prefix = name + "," if future else ""
    ending = "\n" if future else "\r\n"
    if comma < 1:
        return "", f"{prefix}!10 Err: No checksum found but required{ending}"
    expected = checksum(text[:comma])
    given = text[comma + 1:]
    if given.isdigit() and int(given) == expected:
        return text[:comma], ""
    return "", f"{prefix}!9 Err: Checksum incorrect, expected {expected}{ending}"


__all__ = ["ERROR_TEXT", "MISSING", "OK", "PRINTED", "Line", "checksum", "strip_checksum",
           "unknown"]
