"""``terrasph cache list`` and ``terrasph cache clear``: the cached settled states (terrasph.settle_cache)."""

from __future__ import annotations

import argparse
import json

from terrasph.settle_cache import CACHE_ENV, default_cache

__all__ = ["register"]


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Adds the ``cache`` command with its ``list`` and ``clear`` actions."""
    cache = subparsers.add_parser(
        "cache", help="list or clear the cached settled states (the state at the end of a robot scene's pause)",
        description="A robot run on the SPH bed starts from the cached state at the end of its pause when an "
                    "earlier run with the same bed, robot, numerics and code settled it (bit for bit the run "
                    f"that settles itself). The cache lies in ${CACHE_ENV} if set, else the platform's user cache "
                    "directory.")
    cache.add_argument("action", choices=("list", "clear"), help="list: one line per entry; clear: remove them all")
    cache.add_argument("--json", action="store_true", help="list: print the entries as JSON")
    cache.set_defaults(handler=_cmd_cache)


def _cmd_cache(args: argparse.Namespace) -> int:
    store = default_cache()
    if args.action == "clear":
        print(f"removed {store.clear()} cached settled state(s) from {store.root}")
        return 0
    entries = store.entries()
    if args.json:
        print(json.dumps({"root": str(store.root), "entries": entries}, indent=1))
        return 0
    print(f"{store.root}: {len(entries)} cached settled state(s), {sum(e['bytes'] for e in entries) / 1e6:.1f} MB")
    for entry in entries:
        print(f"{entry['key'][:16]}  {entry['scene']}  pause {entry['settle_time']} s  dx {entry['spacing']} m  "
              f"{entry['bytes'] / 1e6:.1f} MB  {entry['created_utc']}")
    return 0
