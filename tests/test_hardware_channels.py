"""LcmChannels: defaults and partial YAML overrides."""

from heft.hardware_interface.channels import LcmChannels
from pydrake.common.yaml import yaml_load_typed


def test_defaults_stay_on_this_machine_and_names_are_unique():
    channels = LcmChannels()
    assert channels.lcm_url.endswith("ttl=0")
    names = [c.name for c in (channels.master_state, channels.master_command, channels.slave_status,
                              channels.slave_command, channels.ft_sample)]
    assert len(set(names)) == len(names)


def test_yaml_overrides_one_field_and_keeps_the_rest():
    channels = yaml_load_typed(schema=LcmChannels, data="{ft_sample: {rate: 1000}}")
    assert channels.ft_sample.rate == 1000.0
    assert channels.ft_sample.name == LcmChannels().ft_sample.name
    assert channels.master_state == LcmChannels().master_state
