//! The deployment files agree with the service: probe paths are served, ports line up from the
//! container to the Service, the container command is the Dockerfile's entrypoint and a valid
//! `preston` invocation, and the autoscaler and disruption budget select the Deployment; the
//! API keys file the container is told to read is the read-only Secret mount; the
//! NetworkPolicy guards these pods' port; everything lives in Preston's namespace; the image's
//! HEALTHCHECK is a `preston healthcheck` the CLI accepts. (Schemas and scanner: `.ci/run`.)

use crate::common;

use clap::Parser;
use common::http::{app, get};
use preston::config::{Cli, Command};
use yaml_rust2::{Yaml, YamlLoader};

fn load(name: &str) -> Yaml {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("deploy/k8s")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut docs = YamlLoader::load_from_str(&text).unwrap();
    assert_eq!(docs.len(), 1, "{name}: one document");
    docs.remove(0)
}

fn strings(y: &Yaml) -> Vec<String> {
    y.as_vec()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_string())
        .collect()
}

fn dockerfile() -> String {
    std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("deploy/Dockerfile"),
    )
    .unwrap()
}

/// The value of the container's environment variable `name`.
fn env_value<'a>(container: &'a Yaml, name: &str) -> Option<&'a str> {
    container["env"]
        .as_vec()?
        .iter()
        .find(|e| e["name"].as_str() == Some(name))
        .and_then(|e| e["value"].as_str())
}

/// The Secret volume that `path` (`<mountPath>/<item path>`) is a file of, mounted read-only.
fn secret_file<'a>(container: &Yaml, pod: &'a Yaml, path: &str) -> &'a Yaml {
    let (dir, file) = path.rsplit_once('/').unwrap();
    let mount = container["volumeMounts"]
        .as_vec()
        .unwrap()
        .iter()
        .find(|m| m["mountPath"].as_str() == Some(dir))
        .unwrap_or_else(|| panic!("{path}: its directory is no mount"));
    assert_eq!(mount["readOnly"].as_bool(), Some(true), "{path}");
    let volume = pod["volumes"]
        .as_vec()
        .unwrap()
        .iter()
        .find(|v| v["name"] == mount["name"])
        .unwrap();
    let secret = &volume["secret"];
    assert!(!secret["secretName"].is_badvalue(), "{path}");
    assert!(
        secret["items"]
            .as_vec()
            .unwrap()
            .iter()
            .any(|i| i["path"].as_str() == Some(file)),
        "{path}"
    );
    secret
}

/// The Dockerfile's instructions, continuation lines joined.
fn instructions() -> Vec<String> {
    dockerfile()
        .replace("\\\n", " ")
        .lines()
        .filter(|l| !l.trim_start().starts_with('#'))
        .map(str::to_string)
        .collect()
}

/// The JSON array after `INSTRUCTION ` in the Dockerfile (exec form).
fn exec_form(instruction: &str) -> Vec<String> {
    let line = instructions()
        .into_iter()
        .find(|l| l.starts_with(&format!("{instruction} ")))
        .unwrap_or_else(|| panic!("no {instruction}"));
    serde_json::from_str(line.split_once(' ').unwrap().1).unwrap()
}

#[tokio::test]
async fn manifests_match_the_service_and_the_image() {
    let deployment = load("deployment.yaml");
    assert_eq!(deployment["kind"].as_str(), Some("Deployment"));
    let labels = &deployment["spec"]["template"]["metadata"]["labels"];
    assert_eq!(&deployment["spec"]["selector"]["matchLabels"], labels);
    let container = &deployment["spec"]["template"]["spec"]["containers"][0];

    // Command: the image's entrypoint, with arguments the CLI accepts.
    let command = strings(&container["command"]);
    assert_eq!(command, exec_form("ENTRYPOINT"));
    let args = strings(&container["args"]);
    assert_eq!(args, exec_form("CMD"));
    Cli::try_parse_from(command.iter().chain(&args)).expect("the container's arguments parse");

    // Port: the listen address in the environment, the container port, the Dockerfile's EXPOSE.
    let env = container["env"].as_vec().unwrap();
    let listen = env_value(container, "PRESTON_LISTEN").unwrap();
    let port: i64 = listen.rsplit(':').next().unwrap().parse().unwrap();
    let container_port = &container["ports"][0];
    assert_eq!(container_port["containerPort"].as_i64(), Some(port));
    assert!(dockerfile().contains(&format!("EXPOSE {port}")));
    assert!(dockerfile().contains(&format!("PRESTON_LISTEN=0.0.0.0:{port}")));
    let port_name = container_port["name"].as_str().unwrap();
    // Every env name is a setting the CLI knows (a typo would be silently ignored otherwise).
    for e in env {
        let name = e["name"].as_str().unwrap();
        let flag = format!(
            "--{}",
            name.trim_start_matches("PRESTON_")
                .to_lowercase()
                .replace('_', "-")
        );
        let value = e["value"].as_str().unwrap();
        Cli::try_parse_from(["preston", "serve", &flag, value])
            .unwrap_or_else(|err| panic!("{name}: {err}"));
    }

    // Probes: paths the router serves with 200, on the named container port.
    let app = app();
    for (probe, path) in [("readinessProbe", "/readyz"), ("livenessProbe", "/healthz")] {
        let http = &container[probe]["httpGet"];
        assert_eq!(http["path"].as_str(), Some(path));
        assert_eq!(http["port"].as_str(), Some(port_name));
        assert_eq!(get(&app, path).await.status, 200, "{path}");
    }
    assert!(
        container["lifecycle"]["preStop"]["sleep"]["seconds"]
            .as_i64()
            .unwrap()
            > 0
    );
    assert!(!container["resources"]["requests"]["cpu"].is_badvalue());
    assert!(!container["resources"]["limits"]["memory"].is_badvalue());
    let scrape = &deployment["spec"]["template"]["metadata"]["annotations"];
    assert_eq!(scrape["prometheus.io/path"].as_str(), Some("/metrics"));
    assert_eq!(get(&app, "/metrics").await.status, 200);

    // Non-root: the pod and the image agree.
    assert_eq!(
        deployment["spec"]["template"]["spec"]["securityContext"]["runAsNonRoot"].as_bool(),
        Some(true)
    );
    assert!(dockerfile().contains("USER nonroot"));
    assert!(
        dockerfile().matches("\nFROM ").count() + usize::from(dockerfile().starts_with("FROM "))
            >= 2,
        "multi-stage"
    );

    // Service → container port; selector → pod labels.
    let service = load("service.yaml");
    assert_eq!(&service["spec"]["selector"], labels);
    assert_eq!(
        service["spec"]["ports"][0]["targetPort"].as_str(),
        Some(port_name)
    );

    // Autoscaler and disruption budget target the Deployment.
    let name = deployment["metadata"]["name"].as_str().unwrap();
    let hpa = load("hpa.yaml");
    assert_eq!(
        hpa["spec"]["scaleTargetRef"]["kind"].as_str(),
        Some("Deployment")
    );
    assert_eq!(hpa["spec"]["scaleTargetRef"]["name"].as_str(), Some(name));
    assert_eq!(
        hpa["spec"]["metrics"][0]["resource"]["name"].as_str(),
        Some("cpu")
    );
    let pdb = load("pdb.yaml");
    assert_eq!(&pdb["spec"]["selector"]["matchLabels"], labels);
}

#[test]
fn keys_come_from_a_read_only_secret_and_only_named_peers_get_in() {
    let deployment = load("deployment.yaml");
    let pod = &deployment["spec"]["template"]["spec"];
    let container = &pod["containers"][0];

    // Every object in Preston's own namespace.
    let namespace = load("namespace.yaml");
    assert_eq!(namespace["kind"].as_str(), Some("Namespace"));
    let ns = namespace["metadata"]["name"].as_str().unwrap();
    assert_ne!(ns, "default");
    for name in [
        "deployment.yaml",
        "service.yaml",
        "hpa.yaml",
        "pdb.yaml",
        "networkpolicy.yaml",
    ] {
        assert_eq!(
            load(name)["metadata"]["namespace"].as_str(),
            Some(ns),
            "{name}"
        );
    }

    // PRESTON_API_KEYS_FILE is <mountPath>/<item path> of a read-only Secret volume.
    let keys_file =
        env_value(container, "PRESTON_API_KEYS_FILE").expect("the container is given a keys file");
    let secret = secret_file(container, pod, keys_file);
    // Readable by the pod's group (fsGroup) only: 0440.
    assert_eq!(secret["defaultMode"].as_i64(), Some(0o440));
    assert_eq!(
        pod["securityContext"]["fsGroup"],
        pod["securityContext"]["runAsGroup"]
    );
    assert_eq!(pod["automountServiceAccountToken"].as_bool(), Some(false));
    assert_eq!(
        pod["securityContext"]["seccompProfile"]["type"].as_str(),
        Some("RuntimeDefault")
    );

    // The NetworkPolicy selects these pods, admits only named sources on the http port and
    // lets them reach only the database (5432) and the cluster DNS (53).
    let policy = load("networkpolicy.yaml");
    assert_eq!(
        &policy["spec"]["podSelector"]["matchLabels"],
        &deployment["spec"]["template"]["metadata"]["labels"]
    );
    let port_name = container["ports"][0]["name"].as_str().unwrap();
    let rules = policy["spec"]["ingress"].as_vec().unwrap();
    assert!(!rules.is_empty());
    for rule in rules {
        let from = rule["from"].as_vec().unwrap();
        assert!(from
            .iter()
            .all(|peer| !peer["namespaceSelector"]["matchLabels"].is_badvalue()));
        assert_eq!(rule["ports"][0]["port"].as_str(), Some(port_name));
    }
    let egress = policy["spec"]["egress"].as_vec().unwrap();
    assert_eq!(egress.len(), 2);
    let ports: Vec<i64> = egress
        .iter()
        .flat_map(|rule| rule["ports"].as_vec().unwrap().iter())
        .map(|p| p["port"].as_i64().unwrap())
        .collect();
    assert_eq!(ports, [5432, 53, 53]);
    for rule in egress {
        // Every destination is named by namespace and pod labels, never "anywhere".
        for peer in rule["to"].as_vec().unwrap() {
            assert!(!peer["namespaceSelector"]["matchLabels"].is_badvalue());
            assert!(!peer["podSelector"]["matchLabels"].is_badvalue());
        }
    }
    // Several replicas share PostgreSQL, its URL from a Secret (never SQLite on a pod's disk).
    assert!(deployment["spec"]["replicas"].as_i64().unwrap() >= 2);
    assert!(env_value(container, "PRESTON_DATABASE_URL").is_none());
    let url_file = env_value(container, "PRESTON_DATABASE_URL_FILE").expect("a database URL file");
    assert_eq!(
        secret_file(container, pod, url_file)["defaultMode"].as_i64(),
        Some(0o440)
    );
    assert!(strings(&policy["spec"]["policyTypes"]).contains(&"Egress".to_string()));
}

#[test]
fn the_image_health_check_is_a_preston_healthcheck() {
    let line = instructions()
        .into_iter()
        .find(|l| l.starts_with("HEALTHCHECK "))
        .expect("a HEALTHCHECK");
    let exec = &line[line.find("CMD [").expect("exec form") + 4..];
    let command: Vec<String> = serde_json::from_str(exec).unwrap();
    assert_eq!(command[0], exec_form("ENTRYPOINT")[0]);
    let cli = Cli::try_parse_from(&command).expect("the health check's arguments parse");
    assert!(matches!(cli.command, Some(Command::Healthcheck { .. })));
}
