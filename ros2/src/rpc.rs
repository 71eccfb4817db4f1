//! The bridge's ROS 2 service servers, made of a ros2-client subscription on the request topic
//! and a RustDDS writer on the reply topic. Unlike `ros2_client::Server`, each request comes with
//! its DDS sample information: the writer GUID (whose prefix is the calling participant, the one
//! DDS Security authenticated), the sequence number and the source timestamp, which the bridge
//! needs to log the caller, forward it to the service and refuse replays. The three RPC-over-DDS
//! mappings are decoded as ros2-client does (`service/wrappers.rs`).

use fri_api::protocol::Ros2Caller;
use ros2_client::dds::rustdds::rpc::SampleIdentity;
use ros2_client::dds::rustdds::{
    self, QosPolicies, SequenceNumber, Timestamp, TopicKind, WriteOptionsBuilder,
};
use ros2_client::{
    Context, Gid, Message, MessageInfo, Name, Node, NodeName, QosProfile, RmwRequestId,
    Subscription,
};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::config::ServiceMappingKind;

/// The Cyclone mapping's header (rmw_cyclonedds): the lower half of the client's GUID and the
/// request's sequence number, in front of the request and of the reply.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct CycloneHeader {
    guid_second_half: [u8; 8],
    sequence_number_high: i32,
    sequence_number_low: u32,
}

/// A request or reply with the Cyclone header.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CycloneWire<M> {
    header: CycloneHeader,
    body: M,
}

/// RPC over DDS `SampleIdentity`: GUID (16 bytes) and sequence number.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct Identity {
    guid: [u8; 16],
    sequence_number_high: i32,
    sequence_number_low: u32,
}

/// A request of the basic mapping: `RequestHeader { request_id, instance_name }` first.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BasicRequest<M> {
    request_id: Identity,
    instance_name: String,
    body: M,
}

/// A reply of the basic mapping: `ReplyHeader { related_request_id, remote_exception_code }`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BasicReply<M> {
    related_request_id: Identity,
    remote_exception_code: u32,
    body: M,
}

fn identity(id: RmwRequestId) -> Identity {
    let sn = SequenceNumber::from(id.sequence_number);
    Identity {
        guid: id.writer_gid.to_bytes16(),
        sequence_number_high: sn.high(),
        sequence_number_low: sn.low(),
    }
}

fn request_id(guid: [u8; 16], high: i32, low: u32) -> RmwRequestId {
    RmwRequestId {
        writer_gid: Gid::from(guid),
        sequence_number: i64::from(SequenceNumber::from_high_low(high, low)),
    }
}

/// A received request with what DDS knows of its sample.
#[derive(Debug, Clone)]
pub struct Request<Q> {
    /// The id the reply carries back (as the client's middleware expects it).
    pub id: RmwRequestId,
    /// The request.
    pub body: Q,
    /// The DDS writer GUID of the sample (the calling participant's prefix).
    pub writer: [u8; 16],
    /// The writer's sequence number of the sample.
    pub sequence_number: i64,
    /// The source timestamp, ns since the Unix epoch (`None`: the sample had none).
    pub source_ns: Option<i64>,
}

impl<Q> Request<Q> {
    /// The calling participant's GUID (the writer's prefix with the participant entity id),
    /// `xxxxxxxx.xxxxxxxx.xxxxxxxx.000001c1`.
    pub fn participant(&self) -> String {
        participant_guid(&self.writer)
    }

    /// The caller as the service records it.
    pub fn caller(&self, authenticated: bool) -> Ros2Caller {
        Ros2Caller {
            participant: self.participant(),
            authenticated,
        }
    }
}

/// The participant GUID of a writer GUID, as `Origin::Ros2` names it.
pub fn participant_guid(writer: &[u8; 16]) -> String {
    let hex = |b: &[u8]| b.iter().map(|x| format!("{x:02x}")).collect::<String>();
    format!(
        "{}.{}.{}.000001c1",
        hex(&writer[0..4]),
        hex(&writer[4..8]),
        hex(&writer[8..12])
    )
}

fn sample<Q>(id: RmwRequestId, body: Q, info: &MessageInfo) -> Request<Q> {
    Request {
        id,
        body,
        writer: info.publisher_gid().to_bytes16(),
        sequence_number: info.sequence_number(),
        source_ns: info.source_timestamp().map(|t| t.to_nanos()),
    }
}

/// The request side of a service, in the peers' mapping.
pub enum Requests<Q: 'static> {
    /// Enhanced mapping: the request alone, the id in the inline QoS.
    Enhanced(Subscription<Q>),
    /// Cyclone mapping.
    Cyclone(Subscription<CycloneWire<Q>>),
    /// Basic mapping.
    Basic(Subscription<BasicRequest<Q>>),
}

impl<Q: DeserializeOwned + 'static> Requests<Q> {
    /// The next request (an error: a sample that does not decode).
    pub async fn next(&self) -> Result<Request<Q>, String> {
        match self {
            Self::Enhanced(s) => {
                let (body, info) = s.async_take().await.map_err(|e| format!("{e:?}"))?;
                let mut id = info.related_request_id().unwrap_or(RmwRequestId {
                    writer_gid: info.publisher_gid(),
                    sequence_number: info.sequence_number(),
                });
                // rmw_fastrtps leaves the sequence number unknown (ros2-client does the same).
                if id.sequence_number == i64::from(SequenceNumber::UNKNOWN) {
                    id.sequence_number = info.sequence_number();
                }
                Ok(sample(id, body, &info))
            }
            Self::Cyclone(s) => {
                let (w, info) = s.async_take().await.map_err(|e| format!("{e:?}"))?;
                let mut guid = info.publisher_gid().to_bytes16();
                guid[8..].copy_from_slice(&w.header.guid_second_half);
                let id = request_id(
                    guid,
                    w.header.sequence_number_high,
                    w.header.sequence_number_low,
                );
                Ok(sample(id, w.body, &info))
            }
            Self::Basic(s) => {
                let (w, info) = s.async_take().await.map_err(|e| format!("{e:?}"))?;
                let r = w.request_id;
                let id = request_id(r.guid, r.sequence_number_high, r.sequence_number_low);
                Ok(sample(id, w.body, &info))
            }
        }
    }
}

type Writer<M> = rustdds::no_key::DataWriterCdr<M>;

/// The reply side of a service, in the peers' mapping.
pub enum Replies<P: Serialize> {
    /// Enhanced mapping: the reply alone, the request's id as related sample identity.
    Enhanced(Writer<P>),
    /// Cyclone mapping.
    Cyclone(Writer<CycloneWire<P>>),
    /// Basic mapping.
    Basic(Writer<BasicReply<P>>),
}

impl<P: Serialize> Replies<P> {
    /// Sends `reply` to the request `id`.
    pub async fn send(&self, id: RmwRequestId, reply: P) -> Result<(), String> {
        let options = WriteOptionsBuilder::new()
            .source_timestamp(Timestamp::now())
            .related_sample_identity(SampleIdentity::from(id))
            .build();
        match self {
            Self::Enhanced(w) => w
                .async_write_with_options(reply, options)
                .await
                .map(drop)
                .map_err(write_error),
            Self::Cyclone(w) => {
                let sn = SequenceNumber::from(id.sequence_number);
                let mut guid_second_half = [0; 8];
                guid_second_half.copy_from_slice(&id.writer_gid.to_bytes16()[8..]);
                let wire = CycloneWire {
                    header: CycloneHeader {
                        guid_second_half,
                        sequence_number_high: sn.high(),
                        sequence_number_low: sn.low(),
                    },
                    body: reply,
                };
                w.async_write_with_options(wire, options)
                    .await
                    .map(drop)
                    .map_err(write_error)
            }
            Self::Basic(w) => {
                let wire = BasicReply {
                    related_request_id: identity(id),
                    remote_exception_code: 0,
                    body: reply,
                };
                w.async_write_with_options(wire, options)
                    .await
                    .map(drop)
                    .map_err(write_error)
            }
        }
    }
}

fn write_error<D>(e: rustdds::dds::result::WriteError<D>) -> String {
    format!("{:?}", e.forget_data())
}

/// A service server: its requests and its replies.
pub struct Service<Q: 'static, P: Serialize> {
    /// The request side.
    pub requests: Requests<Q>,
    /// The reply side.
    pub replies: Replies<P>,
}

/// Creates the server of service `base` in `namespace`, of ROS type `package/srv/type_name`.
#[allow(clippy::too_many_arguments)]
pub fn serve<Q, P>(
    context: &Context,
    node: &mut Node,
    node_name: &NodeName,
    mapping: ServiceMappingKind,
    namespace: &str,
    base: &str,
    (package, type_name): (&str, &str),
    qos: &QosProfile,
) -> Result<Service<Q, P>, String>
where
    Q: Message + DeserializeOwned + 'static,
    P: Message + Serialize + 'static,
{
    let name = Name::new(namespace, base).map_err(|e| format!("name: {e:?}"))?;
    let dds_qos: QosPolicies = qos.into();
    let participant = context.domain_participant();
    let topic = |kind: &str, suffix: &str, ty: &str| {
        participant
            .create_topic(
                name.to_dds_name(kind, node_name, suffix),
                format!("{package}::srv::dds_::{type_name}_{ty}_"),
                &dds_qos,
                TopicKind::NoKey,
            )
            .map_err(|e| format!("topic: {e}"))
    };
    let rq = topic("rq", "Request", "Request")?;
    let rr = topic("rr", "Reply", "Response")?;
    let sub_err = |e: ros2_client::CreateError| format!("request reader: {e:?}");
    let requests = match mapping {
        ServiceMappingKind::Enhanced => Requests::Enhanced(
            node.create_subscription(&rq, Some(qos.clone()))
                .map_err(sub_err)?,
        ),
        ServiceMappingKind::Cyclone => Requests::Cyclone(
            node.create_subscription(&rq, Some(qos.clone()))
                .map_err(sub_err)?,
        ),
        ServiceMappingKind::Basic => Requests::Basic(
            node.create_subscription(&rq, Some(qos.clone()))
                .map_err(sub_err)?,
        ),
    };
    let publisher = participant
        .create_publisher(&dds_qos)
        .map_err(|e| format!("reply publisher: {e}"))?;
    let w_err = |e: rustdds::dds::CreateError| format!("reply writer: {e}");
    let replies = match mapping {
        ServiceMappingKind::Enhanced => Replies::Enhanced(
            publisher
                .create_datawriter_no_key_cdr(&rr, Some(dds_qos.clone()))
                .map_err(w_err)?,
        ),
        ServiceMappingKind::Cyclone => Replies::Cyclone(
            publisher
                .create_datawriter_no_key_cdr(&rr, Some(dds_qos.clone()))
                .map_err(w_err)?,
        ),
        ServiceMappingKind::Basic => Replies::Basic(
            publisher
                .create_datawriter_no_key_cdr(&rr, Some(dds_qos.clone()))
                .map_err(w_err)?,
        ),
    };
    Ok(Service { requests, replies })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_participant_is_the_writer_prefix() {
        let mut w = [0u8; 16];
        for (i, b) in w.iter_mut().enumerate() {
            *b = i as u8;
        }
        let p = participant_guid(&w);
        assert_eq!(p, "00010203.04050607.08090a0b.000001c1");
        assert!(fri_api::origin::Origin::valid_participant(&p));
    }
}
