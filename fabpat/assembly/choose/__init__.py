"""Which pattern goes on which face (paper §5): a spec's ``[patterns]`` rules, family members as candidates,
and where each choice and its catalog energies come from.

``choice`` (one pattern per face), ``members`` (family members as candidates), ``rules`` (the stiffness
rules: graded strips, roundest pairs), ``provenance`` (each chosen pattern's catalog row and solver version).
"""
