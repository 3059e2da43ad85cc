#!/usr/bin/python3
"""The rounding rule every number people read goes through (core/number_format.hpp, with_uncertainty),
held against an independent implementation in exact decimal arithmetic (Python's decimal), property
style: a few thousand random (value, u) pairs over 24 decades, values far larger and far smaller than
their uncertainty, and the edges (u rounding up to the next decade, 0, negative zero, no u).

The rule (GUM 7.2.6): u to two significant digits, the value to the same decimal place; where that
place is more than 6 decimals after the point or the larger of |value| and u reaches 1e6, both as
mantissas of one power of ten, "(2.211 ± 0.013)e-7" (none for 10^0); without a positive finite u, 4 significant digits.

usage: number_rounding_test.py NUMBER_FORMAT_TOOL
"""
import math
import random
import subprocess
import sys
from decimal import ROUND_HALF_EVEN, Decimal


def fixed(d, places):
    """Decimal d at `places` digits after the point (places < 0: a multiple of 10^-places), "-0" as "0"."""
    q = d.quantize(Decimal(1).scaleb(-places), rounding=ROUND_HALF_EVEN)
    text = "{:f}".format(q) if places >= 0 else "{:f}".format(q.quantize(Decimal(1)))
    if text.startswith("-") and set(text[1:]) <= set("0."):
        text = text[1:]
    return text


def expected(value, u):
    if not (u > 0) or math.isinf(u) or math.isnan(u):
        return None  # the value alone: format_number's rule, not this one's
    u2 = Decimal(u).quantize(Decimal(1).scaleb(Decimal(u).adjusted() - 1), rounding=ROUND_HALF_EVEN)
    decimals = 1 - u2.adjusted()  # adjusted(): the exponent of the leading digit; 0.0996 -> 0.10 -> -1
    larger = max(abs(Decimal(value)), u2)
    # Rounded to 16 significant digits first, as "%.15e" does: 9.9999999999999999e5 is 1e6.
    magnitude = larger.quantize(Decimal(1).scaleb(larger.adjusted() - 15), rounding=ROUND_HALF_EVEN).adjusted()
    if (decimals <= 6 and magnitude < 6) or magnitude == 0:
        return "%s \u00b1 %s" % (fixed(Decimal(value), decimals), fixed(u2, decimals))
    v = Decimal(value).scaleb(-magnitude)
    return "(%s \u00b1 %s)e%d" % (fixed(v, decimals + magnitude), fixed(u2.scaleb(-magnitude), decimals + magnitude),
                                 magnitude)


def cases():
    rng = random.Random(20261127)
    out = [(1.23456, 0.0123), (2.2519e-7, 8.5e-10), (-0.0004, 0.03), (-0.0, 0.5), (0.0, 1e-9), (12345.6, 150.0),
           (12345678.0, 150.0), (5.0, 0.0996), (5.0, 0.995), (5.0, 9.96), (-322.359, 0.0406), (0.999678, 3.43e-8),
           (1e-12, 1e-15), (3.0, 2e-6), (3.0, 1.2e-5), (999999.7, 0.3), (-17.4, 1234.0)]
    for _ in range(4000):
        u = 10 ** rng.uniform(-12, 7) * rng.choice((1.0, 0.95, 0.995, 0.9999))
        ratio = 10 ** rng.uniform(-3, 8)
        value = rng.choice((-1, 1)) * u * ratio
        out.append((value, u))
    return out


def main():
    tool = sys.argv[1]
    pairs = cases()
    text = "".join("%r %r\n" % p for p in pairs)
    got = subprocess.run([tool], input=text, capture_output=True, text=True, check=True).stdout.splitlines()
    assert len(got) == len(pairs), (len(got), len(pairs))
    bad = [(p, g, expected(*p)) for p, g in zip(pairs, got) if g != expected(*p)]
    for p, g, e in bad[:20]:
        print("value %r u %r: got %r, expected %r" % (p[0], p[1], g, e))
    # Without u the value alone (its own digits; format_number's rule).
    nou = subprocess.run([tool], input="2.5 nan\n-17.4178 0\n", capture_output=True, text=True, check=True).stdout
    if nou.splitlines() != ["2.500", "-17.42"]:
        bad.append(("no u", nou, "2.500, -17.42"))
        print("without u:", nou.splitlines())
    if bad:
        print("FAIL: %d of %d pairs differ" % (len(bad), len(pairs)))
        return 1
    print("ok: %d pairs rounded as the GUM asks" % len(pairs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
