//! The deployment files agree with the service: probe paths are served, ports line up from the
//! container to the Service, the container command is the Dockerfile's entrypoint and a valid
//! `preston` invocation, and the autoscaler and disruption budget select the Deployment.

use crate::common;

use clap::Parser;
use common::http::{app, get};
use preston::config::Cli;
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

/// The JSON array after `INSTRUCTION ` in the Dockerfile (exec form).
fn exec_form(instruction: &str) -> Vec<String> {
    let line = dockerfile()
        .lines()
        .find(|l| l.starts_with(&format!("{instruction} ")))
        .unwrap_or_else(|| panic!("no {instruction}"))
        .to_string();
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
    let listen = env
        .iter()
        .find(|e| e["name"].as_str() == Some("PRESTON_LISTEN"))
        .and_then(|e| e["value"].as_str())
        .unwrap();
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
