"""yaml_files: bounded, alias-free YAML reading; the same text is parsed once."""

import pytest
from robot_wear_monitor import yaml_files
from robot_wear_monitor.errors import InputError
import yaml


def _count_parses(monkeypatch):
    calls = []
    parse = yaml.load

    def counted(*args, **kwargs):
        calls.append(1)
        return parse(*args, **kwargs)
    monkeypatch.setattr(yaml, 'load', counted)
    return calls


def test_the_same_text_is_parsed_once_and_every_call_gets_its_own_copy(tmp_path, monkeypatch):
    calls = _count_parses(monkeypatch)
    path = tmp_path / 'a.yaml'
    path.write_text('node:\n  values: [1, 2.5, x]\n  nested: {k: true}\n')
    first = yaml_files.load_yaml_file(path)
    first['node']['values'].append('changed')
    second = yaml_files.load_yaml_file(path)
    assert second == {'node': {'values': [1, 2.5, 'x'], 'nested': {'k': True}}}
    assert len(calls) == 1
    path.write_text('node:\n  values: [3, 2.5, x]\n  nested: {k: true}\n')  # same size
    assert yaml_files.load_yaml_file(path)['node']['values'] == [3, 2.5, 'x']
    assert len(calls) == 2


def test_only_the_latest_texts_are_kept_and_errors_are_not(monkeypatch):
    calls = _count_parses(monkeypatch)
    texts = [f'value: {i}\n' for i in range(yaml_files.RECENT_TEXTS + 1)]
    for text in texts:
        assert yaml_files.load_yaml_text(text, source='t') == {'value': int(text[7:])}
    assert yaml_files._parsed.cache_info().currsize <= yaml_files.RECENT_TEXTS
    yaml_files.load_yaml_text(texts[-1], source='t')
    assert len(calls) == len(texts)
    yaml_files.load_yaml_text(texts[0], source='t')  # the oldest was dropped
    assert len(calls) == len(texts) + 1
    for _ in range(2):
        with pytest.raises(InputError, match='aliases'):
            yaml_files.load_yaml_text('a: &x [1]\nb: *x\n', source='bad.yaml')
    assert yaml_files.load_yaml_text('', source='empty') is None
    assert yaml_files.load_yaml_text('', source='empty') is None


@pytest.mark.parametrize('loader', ['libyaml', 'pure Python'])
def test_both_loaders_give_the_same_documents_and_refuse_aliases(monkeypatch, loader):
    from pathlib import Path
    if loader == 'pure Python':
        monkeypatch.setattr(yaml_files, '_C_SAFE_LOADER', None)
    else:
        assert yaml_files._C_SAFE_LOADER is not None  # PyYAML's wheels bring libyaml
    yaml_files._parsed.cache_clear()
    config = Path(__file__).resolve().parents[1] / 'config'
    files = sorted(config.glob('*.yaml'))
    assert len(files) >= 3
    for path in files:
        text = path.read_text(encoding='utf-8')
        assert yaml_files.load_yaml_text(text, source=str(path)) == yaml.load(
            text, Loader=yaml.SafeLoader), path
    text = 'speeds: [1, 2.5e1, .inf]\nname: "x"\nflag: yes\nwhen: 2026-11-26\n'
    assert yaml_files.load_yaml_text(text, source='t') == yaml.load(text, Loader=yaml.SafeLoader)
    for bad in ('a: &x [1]\nb: *x\n', 'a: [1, *unknown]\n'):
        with pytest.raises(InputError, match=r'aliases \(\*name\) are not accepted \(line \d'):
            yaml_files.load_yaml_text(bad, source='bad.yaml')
    with pytest.raises(InputError, match=r'not valid YAML: .* \(line 3, column 1\)'):
        yaml_files.load_yaml_text('name: x\nnoise: [\n', source='bad.yaml')
    yaml_files._parsed.cache_clear()


@pytest.mark.parametrize('loader', ['libyaml', 'pure Python'])
def test_a_deeply_nested_text_is_a_clear_error_not_a_crash(monkeypatch, loader):
    """Nesting past the loaders' reach (a 1 MB file of brackets) is an InputError, no crash."""
    import subprocess
    import sys
    import textwrap
    if loader == 'pure Python':
        monkeypatch.setattr(yaml_files, '_C_SAFE_LOADER', None)
    yaml_files._parsed.cache_clear()
    assert yaml_files.load_yaml_text('[' * 200 + ']' * 200, source='t') == \
        yaml.load('[' * 200 + ']' * 200, Loader=yaml.SafeLoader)
    for depth in (500, 1000, 2000):  # past MAX_YAML_DEPTH (2,000: past libyaml 6.0.4's 1,000)
        with pytest.raises(InputError, match='deep.yaml: YAML nested too deeply'):
            yaml_files.load_yaml_text('[' * depth + ']' * depth, source='deep.yaml')
    yaml_files._parsed.cache_clear()
    # libyaml's composer recurses in C: a deep enough text overflows the stack (a segfault),
    # so this one runs in its own process
    script = textwrap.dedent(f"""
        from robot_wear_monitor import yaml_files
        from robot_wear_monitor.errors import InputError
        if {loader == 'pure Python'}:
            yaml_files._C_SAFE_LOADER = None
        try:
            yaml_files.load_yaml_text('[' * 400_000 + ']' * 400_000, source='deep.yaml')
        except InputError as error:
            print(error)
    """)
    done = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                          timeout=120)
    assert (done.returncode, done.stdout.strip()) == (0, 'deep.yaml: YAML nested too deeply')


@pytest.mark.parametrize('words', ['exceeded maximum nesting depth', 'some other wording'])
def test_a_libyaml_that_refuses_deep_nesting_in_its_own_words_gives_the_same_error(
        monkeypatch, words):
    """
    Whatever libyaml's limit and wording (PyYAML 6.0.4: 1,000 levels), the error is ours.

    The stand-in for libyaml reads a few levels, then refuses as its scanner would, before
    any event past :data:`~robot_wear_monitor.yaml_files.MAX_YAML_DEPTH` reached the reader;
    an error that is not about nesting keeps libyaml's own words and place.
    """
    parse = yaml.parse

    def refusing(text, Loader):  # noqa: N803 - yaml's keyword
        if Loader is not yaml_files._C_SAFE_LOADER:
            yield from parse(text, Loader=Loader)
            return
        for number, event in enumerate(parse(text[:40], Loader=yaml.SafeLoader)):
            if number == 20:
                raise yaml.scanner.ScannerError(
                    'while scanning', None, words, yaml.error.Mark('<unicode>', 1000, 0, 1000,
                                                                   None, None))
            yield event
    monkeypatch.setattr(yaml_files, '_C_SAFE_LOADER', object())
    monkeypatch.setattr(yaml, 'parse', refusing)
    yaml_files._parsed.cache_clear()
    depth = 400_000
    with pytest.raises(InputError) as deep:
        yaml_files.load_yaml_text('[' * depth + ']' * depth, source='deep.yaml')
    assert str(deep.value) == 'deep.yaml: YAML nested too deeply'
    shallow = '[' * 50 + ']' * 50 + '\n'  # valid YAML: libyaml's refusal stands, in its words
    with pytest.raises(InputError) as refused:
        yaml_files.load_yaml_text(shallow, source='flat.yaml')
    assert str(refused.value) == f'flat.yaml: not valid YAML: {words} (line 1, column 1001)'
    yaml_files._parsed.cache_clear()
