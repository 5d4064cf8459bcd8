"""YAML read as plain values, Drake's tags (``!Rpy {deg: …}``, ``!AngleAxis …``) as the values they tag: what
the checks that name a file's fields read before Drake's typed loader reads the file (scenarios, recordings)."""

import yaml


class _TaggedLoader(yaml.SafeLoader):
    """A safe loader that reads any ``!Tag`` node as its plain mapping, sequence or scalar."""


def _untagged(loader, suffix, node):
    if isinstance(node, yaml.MappingNode):
        return loader.construct_mapping(node, deep=True)
    if isinstance(node, yaml.SequenceNode):
        return loader.construct_sequence(node, deep=True)
    return loader.construct_scalar(node)


_TaggedLoader.add_multi_constructor("!", _untagged)


def yaml_tree(text: str):
    """The YAML ``text`` as plain Python values ({} if empty); a ``yaml.YAMLError`` if it is not YAML."""
    tree = yaml.load(text, Loader=_TaggedLoader)
    return {} if tree is None else tree
