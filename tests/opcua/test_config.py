"""The ``[opcua]`` section: check-config names each bad key, ``opcua-cert`` makes the server's
certificate with the application URI."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
from cryptography import x509

from gateway.cli import main
from tests.support.config_checks import problems_of

DIGEST = hashlib.sha256(b"operator-token-0123456789").hexdigest()


def _cell(tmp_path: Path, opcua: str, *, tokens: bool = True) -> Path:
    token = f'[[security.tokens]]\nname = "op"\nrole = "operator"\nsha256 = "{DIGEST}"\n'
    path = tmp_path / "cell.toml"
    path.write_text(
        f'state_dir = "{tmp_path / "state"}"\n'
        '[[loops]]\nname = "main"\nport = "socket://127.0.0.1:4001"\n'
        '[[loops.controllers]]\nbody = "1"\n' + (token if tokens else "") + f"[opcua]\n{opcua}\n"
    )
    return path


@pytest.mark.parametrize(
    ("section", "key", "words"),
    [
        ('endpoint = "http://0.0.0.0:4840"', "opcua.endpoint", "should match pattern"),
        ('endpoint = "opc.tcp://0.0.0.0:70000"', "opcua", "port 70000 is not 1-65535"),
        ('security_policies = ["Basic128Rsa15"]', "opcua.security_policies[0]", "Input should be"),
        ("security_policies = []", "opcua.security_policies", "at least 1 item"),
        ('certificate = "/x.der"', "opcua", "certificate and private_key go together"),
        ('certificate = "/no/x.der"\nprivate_key = "/no/x.pem"', "opcua.certificate",
         "is not a file"),
        ('trusted_clients = "/no/such"', "opcua.trusted_clients", "is not a directory"),
        ("anonymus = true", "opcua.anonymus", "Extra inputs are not permitted"),
    ],
)  # fmt: skip
def test_check_config_names_each_bad_key_of_the_section(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], section: str, key: str, words: str
) -> None:
    path = _cell(tmp_path, section)
    assert main(["check-config", str(path)]) == 1
    problems = problems_of(capsys.readouterr().out)
    assert key in problems, problems
    assert words in problems[key]


def test_nobody_could_log_in_without_tokens_or_anonymous(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _cell(tmp_path, "anonymous = false", tokens=False)
    assert main(["check-config", "--no-auth", str(path)]) == 1
    assert "nobody could log in" in problems_of(capsys.readouterr().out)["opcua"]
    path = _cell(tmp_path, "anonymous = true", tokens=False)
    assert main(["check-config", "--no-auth", str(path)]) == 0


def test_opcua_cert_makes_the_certificate_with_the_application_uri(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _cell(tmp_path, 'application_uri = "urn:plant:cell-7"')
    assert main(["opcua-cert", "--config", str(path)]) == 0
    cert_file = tmp_path / "state" / "opcua" / "server-cert.der"
    cert = x509.load_der_x509_certificate(cert_file.read_bytes())
    names = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert "urn:plant:cell-7" in names.get_values_for_type(x509.UniformResourceIdentifier)
    key_file = tmp_path / "state" / "opcua" / "server-key.pem"
    assert key_file.stat().st_mode & 0o077 == 0  # the key is the owner's alone
    said = capsys.readouterr().out
    assert said.startswith(f"made {cert_file}")
    assert hashlib.sha1(cert_file.read_bytes()).hexdigest() in said
    # again: kept; --renew: a new one
    assert main(["opcua-cert", "--config", str(path)]) == 0
    assert capsys.readouterr().out.startswith("kept")
    before = cert_file.read_bytes()
    assert main(["opcua-cert", "--config", str(path), "--renew"]) == 0
    assert cert_file.read_bytes() != before


def test_opcua_cert_needs_the_section(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _cell(tmp_path, "")
    path.write_text(path.read_text().replace("[opcua]\n", ""))
    assert main(["opcua-cert", "--config", str(path)]) == 2
    assert "no [opcua] section" in capsys.readouterr().err
